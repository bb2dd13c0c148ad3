"""The algorithms by name: each maps to its config class as a "module:attribute" string,
imported when first used (`config_class`), so the command line lists the algorithms and
checks `--algo` without importing torch. The configs live in modules that import no torch
(rl/configs.py, rl/dreamer/config.py); the agents are built by rl.agents.build_agent. A new
algorithm is a new entry here, its config, its agent in build_agent and its presets
(rl/presets.py).
"""

from __future__ import annotations

from assetgen.core.references import load_reference

ALGOS: dict[str, str] = {
    "ppo": "rl.configs:PPOConfig",
    "sac": "rl.configs:SACConfig",
    "dreamer": "rl.dreamer.config:DreamerConfig",
    "random": "rl.configs:RandomConfig",
}
"""Algorithm name -> "module:attribute" of its config class."""


def config_class(algo: str) -> type:
    """The config class of `algo`; KeyError for a name that is not registered."""
    return load_reference(ALGOS[algo])
