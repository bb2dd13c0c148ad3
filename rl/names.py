"""Names of the algorithms and presets, importable without torch: the CLI builds its
parsers from them at every start, and importing torch there costs ~1.4 s on each `assetgen`
command (sample, check, info included). rl.agents.ALGOS and rl.presets.PRESETS hold what
the names stand for; tests/test_cli.py holds the two in step."""

ALGO_NAMES = ("dreamer", "ppo", "random", "sac")
PRESET_NAMES = ("cpu", "debug", "paper")
