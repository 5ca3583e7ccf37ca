"""The FMU run-time: the numpy-only modules that travel inside every pythonfmu FMU.

``python build_fmu.py`` copies this sub-package into each FMU under a private,
content-hashed package name (a module name is global to the host process), so
everything here imports only itself (relatively), numpy and the standard
library; a test keeps it so. The modules:

* :mod:`.errors` - the one exception type of bodyvib;
* :mod:`.inputfile` - the one check of an input file (a readable regular file);
* :mod:`.jsonfile` - reading JSON files (the FMU writes nothing);
* :mod:`.network` - lumped networks and their state space;
* :mod:`.modelfile` - the parameter-file format;
* :mod:`.discretize` - exact discretization;
* :mod:`.contract` - the FMU variables, units and value references;
* :mod:`.engine` - the stepping engine of one FMU instance;
* :mod:`.tabulated` - the tabulated source kind (Road.fmu: a baked table, Hermite-interpolated);
* :mod:`.cores` - every FMU kind in one table (`CORES`) behind one protocol (`Core`);
* :mod:`.teardown` - the pythonfmu 0.7.0 exit-time workaround.
"""
