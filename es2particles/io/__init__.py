"""Files and displays: atomic writes of images, animations and state, reading images and colour
ramps, progress lines, and pictures a notebook shows."""
