"""The paper's task, independent of the engine: its numbers (config.py), observation, reward,
success, failure and spawn (rules.py, rules_torch.py for the device), the per-step kernels
(kernel.py), the curricula (curriculum.py, module_replay.py) and a scripted expert
(expert.py)."""
