"""Running and storing simulations: the scheduler every study uses, the local and Dask executors, the isolated simulation process, the HDF5 store."""
