"""The simulated machine: its hidden truth, its physics, and the stack of simulated
endpoints served over it (the device emulators themselves live in ``ogacq_drivers.sim``)."""
