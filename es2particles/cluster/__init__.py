"""Scale-out: a still drawn in shares of particles, and frames or shares as tasks on a Dask
cluster."""
