"""Benchmarks of the simulator: throughput (throughput.py), env build and load time
(build.py, load.py), and the contact stress benchmark (the stress/ package: its cases,
figures and command, and a runner for each engine)."""
