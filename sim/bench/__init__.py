"""Benchmarks of the simulator: throughput (throughput.py), env build and load time
(build.py, load.py), and the contact stress benchmark (stress.py, with stress_physx.py and
stress_warp.py for the other engines)."""
