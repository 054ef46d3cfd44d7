"""The frame as one plan: particle quantities and their textures, the pass graph of a simulation
step, the plan of a whole frame (simulation, render and post stages), its executor on EGL, and the
pipeline whose frames the command line, notebooks and the cluster iterate."""
