"""Files and displays: atomic writes of images, animations and state, reading images, progress
lines, and pictures a notebook shows."""
