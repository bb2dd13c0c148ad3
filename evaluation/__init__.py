"""Evaluation in one place: the paper's protocol (protocol.py), resumable snapshots
(snapshots.py), recorded episodes (recording.py) and assemblies played stage by stage
(sequence.py). It may use both the simulator and the agents."""
