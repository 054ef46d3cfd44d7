"""A scene as one self-contained WebGL 1 page: the frame plan serialised, run by a small executor in
the browser."""
