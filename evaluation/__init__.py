"""Evaluation in one place: the paper's protocol (protocol.py), the `assetgen eval` command
(command.py), the frozen-policy probe of training runs (probe.py), resumable snapshots
(snapshots.py), recorded episodes (recording.py) and assemblies played stage by stage
(sequence.py). It may use both the simulator and the agents; neither imports it."""
