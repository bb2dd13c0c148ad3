"""`assetgen report`: runs and evaluation files in, figures, Table III and report.json out.

Fake runs use the runner's real metrics columns; one test makes every input with the real
writers (a toy-env training run, rl's eval writer, the simulator's scripted evaluation).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from rl.metrics import BASE_COLUMNS
from rl.report import write_report
from rl.report_load import ReportError, load_eval, load_run, variant_name
from rl.report_summary import summarise
from rl.report_tables import markdown_table


def fake_run(
    path: Path,
    algo: str,
    stack: int,
    seed: int,
    steps: list[int],
    rates: list[float],
    walls: list[float] | None = None,
) -> Path:
    """A run folder as rl/runner.py train() writes it (config.json, metrics.csv); walls: the
    wall_s column (default: one second per 100 env steps)."""
    walls = walls if walls is not None else [s / 100 for s in steps]
    path.mkdir(parents=True)
    meta = {"algo": algo, "stack": stack, "seed": seed, "config": {}, "num_envs": 4}
    (path / "config.json").write_text(json.dumps(meta))
    with open(path / "metrics.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=BASE_COLUMNS)
        w.writeheader()
        for i, (s, r, t) in enumerate(zip(steps, rates, walls, strict=True)):
            row = {"iteration": i + 1, "env_steps": s, "success_rate": r, "wall_s": t}
            w.writerow({k: 0 for k in BASE_COLUMNS} | row)
    return path


def fake_eval(path: Path, dataset: str, rate: float, episodes: int, tts: list[float], **who):
    """An evaluation JSON with the keys both `assetgen eval --out` writers produce."""
    doc = {"dataset": dataset, "episodes": episodes, "success_rate": rate,
           "successes": len(tts), "time_to_success_s": tts,
           "median_time_to_success_s": float(np.median(tts)) if tts else None} | who  # fmt: skip
    path.write_text(json.dumps(doc))
    return path


def check_png(path: Path) -> None:
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape[0] >= 300 and img.shape[1] >= 500
    assert img.std() > 10  # not a blank canvas
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20  # lines, text, bands


def test_variant_names() -> None:
    assert variant_name("sac", 10) == "SAC-STACK"
    assert variant_name("ppo", 1) == "PPO"
    assert variant_name("ppo", 4) == "PPO-STACK4"
    assert variant_name("random", 1) == "random"


def test_two_seeds_mean_std_and_table_by_hand(tmp_path: Path) -> None:
    a = fake_run(tmp_path / "runs/sac_s0", "sac", 10, 0, [100, 200, 300], [0.0, 0.2, 0.6])
    b = fake_run(tmp_path / "runs/sac_s1", "sac", 10, 1, [100, 200, 300], [0.2, 0.4, 1.0])
    fake_eval(a / "eval_test.json", "datasets/test", 0.5, 10, [1.0, 2.0, 3.0, 4.0, 5.0],
              algo="sac", stack=10)  # fmt: skip
    fake_eval(b / "eval_test.json", "datasets/test", 0.7, 10, [6.0] * 7, algo="sac", stack=10)
    fake_eval(b / "eval_train.json", "train", 0.9, 10, [2.0] * 9, algo="sac", stack=10)
    base = tmp_path / "results"
    base.mkdir()
    fake_eval(base / "scripted_test.json", "/x/datasets/test", 1.0, 4, [3.0, 3.5, 4.0, 4.5],
              agent="scripted")  # fmt: skip
    fake_eval(base / "random_test.json", "/x/datasets/test", 0.0, 4, [], agent="random")

    doc = write_report([a, b], [base], tmp_path / "report")
    sac = doc["variants"]["SAC-STACK"]
    assert sac["seeds"] == [0, 1]
    assert sac["curve"]["env_steps"] == [100, 200, 300]
    np.testing.assert_allclose(sac["curve"]["success_mean"], [0.1, 0.3, 0.8])
    np.testing.assert_allclose(sac["curve"]["success_std"], [0.1, 0.1, 0.2])  # |a - b| / 2
    test = sac["eval"]["test"]
    assert test["success_mean"] == pytest.approx(0.6) and test["success_std"] == pytest.approx(0.1)
    assert test["episodes"] == 20 and test["successes"] == 12
    assert test["median_time_to_success_s"] == 6.0  # pooled: 1..5 and seven 6.0 -> 6.0
    assert doc["variants"]["random"]["eval"]["test"]["median_time_to_success_s"] is None

    table = (tmp_path / "report/table.md").read_text()
    rows = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:-1]]
            for r in table.splitlines() if r.startswith("| ") and "---" not in r}  # fmt: skip
    assert rows["agent"][:6] == ["seeds", "env steps", "wall clock", "train set", "test set",
                                 "median time to success (test)"]  # fmt: skip
    assert rows["SAC-STACK"][:3] == ["2", "300", "0.1 min"]  # 300 steps at 100 a second
    assert rows["SAC-STACK"][3:6] == ["90.00 % (n = 10)", "60.00 ± 10.00 % (n = 20)", "6.00 s"]
    assert rows["SAC-STACK"][6:] == ["82.97 %", "54.70 %", "2.22 s"]  # the paper's, alongside
    assert rows["scripted"][1:6] == ["–", "–", "–", "100.00 % (n = 4)", "3.75 s"]
    assert rows["random"][1:6] == ["–", "–", "–", "0.00 % (n = 4)", "–"]
    assert rows["PPO"][:6] == ["–"] * 6  # no run: every cell missing
    assert list(rows)[1:] == ["random", "PPO", "PPO-STACK", "SAC", "SAC-STACK", "DreamerV3",
                              "scripted"]  # fmt: skip
    check_png(tmp_path / "report/learning_curves.png")
    check_png(tmp_path / "report/time_to_success.png")
    assert json.loads((tmp_path / "report/report.json").read_text()) == doc


def test_curves_cut_at_the_shortest_seed_and_skip_unfinished_iterations(tmp_path: Path) -> None:
    # seed 1 logged NaN (no finished episode) at 100 and stopped at 300
    a = fake_run(tmp_path / "a", "ppo", 1, 0, [100, 200, 300, 400], [0.0, 0.2, 0.4, 0.6])
    b = fake_run(tmp_path / "b", "ppo", 1, 1, [100, 150, 300], [math.nan, 0.5, 0.5])
    c = summarise([load_run(a), load_run(b)], [])["curves"]["PPO"]
    assert c.runs == 2 and c.env_steps.tolist() == [150, 200, 300]
    # seed 0 at 150 interpolates to 0.1; seed 1 at 200 holds 0.5
    np.testing.assert_allclose(c.mean, [0.3, 0.35, 0.45])
    np.testing.assert_allclose(c.std, [0.2, 0.15, 0.05])


def test_wall_clock_curves_and_training_budgets(tmp_path: Path) -> None:
    """The second panel's curve is over each seed's own wall-clock minutes (seeds that ran at
    different speeds reach a step count at different times); the table gives the budgets'
    means over the seeds."""
    a = fake_run(tmp_path / "a", "sac", 1, 0, [1_000_000, 2_000_000], [0.2, 0.6], [600, 1200])
    b = fake_run(tmp_path / "b", "sac", 1, 1, [1_500_000, 3_000_000], [0.4, 1.0], [600, 1200])
    summary = summarise([load_run(a), load_run(b)], [])
    wall, steps = summary["wall_curves"]["SAC"], summary["curves"]["SAC"]
    assert wall.runs == 2 and wall.env_steps.tolist() == [10.0, 20.0]  # minutes
    np.testing.assert_allclose(wall.mean, [0.3, 0.8])
    np.testing.assert_allclose(wall.std, [0.1, 0.2])
    # over env steps the curves only share 1.5 M to 2 M, where both seeds go 0.4 -> 0.6
    assert steps.env_steps.tolist() == [1_500_000, 2_000_000]
    np.testing.assert_allclose(steps.mean, [0.4, 0.6])
    np.testing.assert_allclose(steps.std, [0.0, 0.0], atol=1e-12)
    table = markdown_table(summary)
    assert "| SAC | 2 | 2.50 M | 20 min |" in table
    doc = write_report([a, b], [], tmp_path / "out")
    assert doc["variants"]["SAC"]["wall_curve"]["wall_min"] == [10.0, 20.0]
    assert doc["variants"]["SAC"]["budgets"] == [
        {"env_steps": 2_000_000, "wall_s": 1200.0},
        {"env_steps": 3_000_000, "wall_s": 1200.0},
    ]
    img = np.asarray(Image.open(tmp_path / "out/learning_curves.png").convert("RGB"))
    assert img.shape[1] >= 2 * img.shape[0]  # two panels side by side
    check_png(tmp_path / "out/learning_curves.png")


def test_a_long_wall_clock_curve_is_thinned_to_even_points(tmp_path: Path) -> None:
    from rl.report_summary import WALL_POINTS

    steps = list(range(100, 100 * 1001, 100))
    walls = [0.37 * i + 0.001 * (i % 7) for i in range(1, 1001)]  # uneven log times
    a = fake_run(tmp_path / "a", "ppo", 1, 0, steps, [0.5] * 1000, walls)
    c = summarise([load_run(a)], [])["wall_curves"]["PPO"]
    assert len(c.env_steps) == WALL_POINTS
    np.testing.assert_allclose(np.diff(c.env_steps), np.diff(c.env_steps)[0])
    assert c.env_steps[0] == pytest.approx(walls[0] / 60)
    assert c.env_steps[-1] == pytest.approx(walls[-1] / 60)
    np.testing.assert_allclose(c.mean, 0.5)


def test_run_without_evaluations_still_gets_its_curve(tmp_path: Path) -> None:
    run = fake_run(tmp_path / "ppo", "ppo", 10, 0, [64, 128], [0.0, 0.5])
    doc = write_report([run], [], tmp_path / "out")
    assert doc["variants"]["PPO-STACK"]["curve"]["success_mean"] == [0.0, 0.5]
    assert doc["variants"]["PPO-STACK"]["eval"] == {}
    table = (tmp_path / "out/table.md").read_text()
    assert "| PPO-STACK | 1 | 128 | 0.0 min | – | – | – | 20.52 % | 20.10 % | – |" in table
    check_png(tmp_path / "out/learning_curves.png")
    check_png(tmp_path / "out/time_to_success.png")  # says there is no test-set evaluation


def test_not_a_run_is_a_clear_error_naming_the_path(tmp_path: Path) -> None:
    only_config = tmp_path / "half"
    only_config.mkdir()
    (only_config / "config.json").write_text("{}")
    (tmp_path / "results").mkdir()  # a folder of eval files given as a run by mistake
    for bad in (tmp_path / "results", only_config, tmp_path / "missing"):
        with pytest.raises(ReportError, match=f"{bad} is not a training run.*config.json and "
                           "metrics.csv"):  # fmt: skip
            write_report([bad], [], tmp_path / "out")
    assert not (tmp_path / "out").exists()  # nothing written before the input is read
    bad_eval = fake_eval(tmp_path / "e.json", "test", 0.5, 2, [1.0])  # neither algo nor agent
    with pytest.raises(ReportError, match=r"e\.json: not an evaluation file"):
        load_eval(bad_eval)
    run = fake_run(tmp_path / "r", "sac", 1, 0, [8], [0.0])
    fake_eval(run / "eval_test.json", "test", 0.5, 2, [1.0], algo="ppo", stack=1)
    with pytest.raises(ReportError, match=r"evaluates PPO, but the run .* is SAC"):
        load_run(run)


def test_cli_parser_runs_the_report_and_fails_cleanly(tmp_path: Path, capsys) -> None:
    from rl.commands import add_report_parser

    parser = argparse.ArgumentParser()
    add_report_parser(parser.add_subparsers())
    run = fake_run(tmp_path / "run", "sac", 1, 0, [8, 16], [0.0, 1.0])
    args = parser.parse_args(["report", str(run), "--out", str(tmp_path / "rep")])
    assert args.func(args) == 0
    assert "| SAC | 1 | 16 | 0.0 min | – | – |" in capsys.readouterr().out
    args = parser.parse_args(["report", str(tmp_path), "--out", str(tmp_path / "rep2")])
    assert args.func(args) == 2
    assert "is not a training run" in " ".join(capsys.readouterr().err.split())


def test_real_writers_end_to_end(tmp_path: Path) -> None:
    """A toy-env training run per seed, `eval --checkpoint --out` through rl's writer, and a
    scripted baseline through the simulator's writer, all into one report."""
    import torch

    from evaluation.command import eval_main
    from rl.ppo import PPOConfig
    from rl.presets import Setup
    from rl.runner import train
    from tests.test_sim_common import sim_dataset
    from tests.toy_env import ToyEnv

    torch.set_num_threads(1)
    setup = Setup(PPOConfig(hidden=(16,), horizon=8, minibatch_size=16, epochs=1), 4, 64, 64)
    runs = []
    for seed in (0, 1):
        out = tmp_path / f"runs/ppo_s{seed}"
        train("ppo", ToyEnv(4), setup, seed=seed, out_dir=out, stack=2, progress=False,
              tensorboard=False)  # fmt: skip
        args = argparse.Namespace(run=out, dataset="test", episodes=2, envs=None, seed=0,
                                  device="cpu", stochastic=False, json=False,
                                  out=out / "eval_test.json")  # fmt: skip
        assert eval_main(args, lambda dataset, n, seed, **kw: ToyEnv(n or 4)) == 0
        runs.append(out)
    stored = json.loads((runs[0] / "eval_test.json").read_text())
    assert {"algo", "stack", "dataset", "run", "episodes", "success_rate",
            "time_to_success_s"} <= stored.keys()  # fmt: skip

    test_split = tmp_path / "datasets/test"  # the folder's name is the split's
    test_split.parent.mkdir()
    test_split.symlink_to(sim_dataset(), target_is_directory=True)
    sim_args = argparse.Namespace(agent="scripted", run=None, dataset=str(test_split),
                                  episodes=1, seed=0, envs=4, record=None, record_limit=None,
                                  out=tmp_path / "results/scripted.json", json=True)  # fmt: skip
    assert eval_main(sim_args) == 0

    (tmp_path / "results/bench_sim.json").write_text('{"env_steps_per_s": 1.0}')
    doc = write_report(runs, [tmp_path / "results"], tmp_path / "report")
    assert doc["skipped_baselines"] == [str(tmp_path / "results/bench_sim.json")]
    (tmp_path / "results/broken.json").write_text('{"success_rate": ')  # unreadable: an error
    with pytest.raises(ReportError, match=r"broken\.json"):
        write_report(runs, [tmp_path / "results"], tmp_path / "report")
    with pytest.raises(ReportError, match=r"bench_sim\.json: not an evaluation file"):
        write_report(runs, [tmp_path / "results/bench_sim.json"], tmp_path / "report")
    ppo = doc["variants"]["PPO-STACK2"]  # stack 2: not the paper's 10
    assert ppo["seeds"] == [0, 1] and ppo["curve"]["runs"] <= 2
    assert ppo["eval"]["test"]["episodes"] == 2 * 4 * 2  # 2 seeds x 4 envs x 2 episodes
    rates = [json.loads((r / "eval_test.json").read_text())["success_rate"] for r in runs]
    assert ppo["eval"]["test"]["success_mean"] == pytest.approx(np.mean(rates))
    scripted = doc["variants"]["scripted"]["eval"]["test"]
    assert scripted["episodes"] == 4 and scripted["files"] == 1
    check_png(tmp_path / "report/time_to_success.png")
    assert "| scripted |" in markdown_table(summarise([load_run(r) for r in runs], []))


def test_protocols_and_recipes_make_their_own_rows(tmp_path: Path) -> None:
    """Sampled actions, demonstrations and overrides never pool with the plain rows."""
    assert variant_name("sac", 1, "scripted") == "SAC+scripted"
    assert variant_name("scripted-fast", 1) == "scripted-fast"
    assert variant_name("sac", 1, "scripted", {"bc_weight": 0.0}) == "SAC+scripted [bc_weight=0.0]"
    a = fake_run(tmp_path / "runs/ppo_s0", "ppo", 1, 0, [100, 200], [0.1, 0.5])
    fake_eval(a / "eval_test.json", "test", 0.6, 10, [2.0] * 6, algo="ppo", stack=1,
              policy="deterministic")  # fmt: skip
    fake_eval(a / "eval_test_sampled.json", "test", 0.9, 10, [1.0] * 9, algo="ppo", stack=1,
              policy="stochastic")  # fmt: skip
    b = fake_run(tmp_path / "runs/sacd_s0", "sac", 1, 0, [100, 200], [0.5, 0.9])
    meta = json.loads((b / "config.json").read_text())
    meta |= {"demos": "scripted", "overrides": {"bc_weight": 0.0}}
    (b / "config.json").write_text(json.dumps(meta))
    fake_eval(b / "eval_test.json", "test", 0.95, 20, [1.0] * 19, algo="sac", stack=1,
              demos="scripted", overrides={"bc_weight": 0.0})  # fmt: skip
    doc = write_report([a, b], [], tmp_path / "report")
    assert doc["variants"]["PPO"]["eval"]["test"]["success_mean"] == pytest.approx(0.6)
    assert doc["variants"]["PPO (sampled)"]["eval"]["test"]["success_mean"] == pytest.approx(0.9)
    sac = doc["variants"]["SAC+scripted [bc_weight=0.0]"]
    assert sac["seeds"] == [0] and sac["eval"]["test"]["episodes"] == 20
    assert "SAC" not in doc["variants"] or not doc["variants"]["SAC"].get("eval")
    # a second file of the same split and policy is refused; a bad policy too
    fake_eval(a / "eval_test2.json", "test", 0.5, 10, [2.0] * 5, algo="ppo", stack=1)
    with pytest.raises(ReportError, match="two evaluation files"):
        write_report([a], [], tmp_path / "report")
    (a / "eval_test2.json").unlink()
    fake_eval(a / "eval_test2.json", "test", 0.5, 10, [2.0] * 5, algo="ppo", stack=1,
              policy="greedy")  # fmt: skip
    with pytest.raises(ReportError, match="greedy"):
        write_report([a], [], tmp_path / "report")


def test_readme_table_is_replaced_between_its_markers(tmp_path: Path) -> None:
    from rl.report import TABLE_BEGIN, TABLE_END, replace_table

    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n\nbefore\n{TABLE_BEGIN}\nold\n{TABLE_END}\nafter\n")
    replace_table(readme, "| a |\n|---|\n")
    assert readme.read_text() == f"# x\n\nbefore\n{TABLE_BEGIN}\n| a |\n|---|\n{TABLE_END}\nafter\n"
    readme.write_text("no markers\n")
    with pytest.raises(ReportError, match="shipped-table:begin"):
        replace_table(readme, "| a |")
    assert readme.read_text() == "no markers\n"


def test_probe_curves_from_the_probe_rows_only(tmp_path: Path) -> None:
    from rl.metrics import PROBE_COLUMNS

    def probed(path: Path, seed: int, probe: dict[int, float]) -> Path:
        fake_run(path, "sac", 1, seed, [64, 128, 192, 256], [0.9, 0.95, 1.0, 1.0])
        rows = list(csv.DictReader(open(path / "metrics.csv")))
        cols = (*BASE_COLUMNS, *PROBE_COLUMNS)
        with open(path / "metrics.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=cols, restval="")
            w.writeheader()
            for r in rows:
                s = int(r["env_steps"])
                w.writerow(r | ({"probe_success_rate": probe[s]} if s in probe else {}))
        return path

    a = probed(tmp_path / "a", 0, {128: 0.2, 256: 0.6})
    b = probed(tmp_path / "b", 1, {128: 0.4, 256: 0.4})
    runs = [load_run(a), load_run(b)]
    assert runs[0].probe_env_steps.tolist() == [128, 256]
    c = summarise(runs, [])["probe_curves"]["SAC"]
    assert c.runs == 2 and c.env_steps.tolist() == [128, 256]
    np.testing.assert_allclose(c.mean, [0.3, 0.5])
    np.testing.assert_allclose(c.std, [0.1, 0.1])
    doc = write_report([a, b], [], tmp_path / "out")
    assert doc["variants"]["SAC"]["probe_curve"]["success_mean"] == pytest.approx([0.3, 0.5])
    check_png(tmp_path / "out/probe_curves.png")
    plain = fake_run(tmp_path / "plain", "ppo", 1, 0, [64, 128], [0.0, 0.5])
    assert summarise([load_run(plain)], [])["probe_curves"] == {}
    write_report([plain], [], tmp_path / "out2")
    assert not (tmp_path / "out2/probe_curves.png").exists()


def test_noise_scaled_evaluations_get_their_own_column(tmp_path: Path) -> None:
    run = fake_run(tmp_path / "sac", "sac", 1, 0, [64, 128], [0.0, 0.5])
    who = {"algo": "sac", "stack": 1}
    fake_eval(run / "eval_test.json", "datasets/test", 0.9, 10, [1.0] * 9, **who)
    fake_eval(run / "eval_test_noise2.json", "datasets/test", 0.6, 10, [2.0] * 6,
              noise_scale=2.0, **who)  # fmt: skip
    fake_eval(run / "eval_test_c025.json", "datasets/test_c025", 0.7, 10, [3.0] * 7, **who)
    summary = summarise([load_run(run)], [])
    assert summary["splits"][-2:] == ["test (noise ×2)", "test_c025"]
    cells = summary["cells"]["SAC"]
    assert cells["test"].success_mean == 0.9 and cells["test (noise ×2)"].success_mean == 0.6
    assert "| test (noise ×2) set |" in markdown_table(summary)


def test_the_readme_table_puts_sampled_actions_beside_the_mean_and_test_only(
    tmp_path: Path,
) -> None:
    """compact_table: one line per agent (its sampled-action figure in a cell, not a row of
    its own), the test split only, a link to the full page for the rest."""
    from rl.report_tables import compact_table

    runs = []
    for seed, (det, smp) in enumerate([(0.8, 0.9), (0.6, 0.7)]):
        run = fake_run(tmp_path / f"sac{seed}", "sac", 1, seed, [64, 128], [0.0, 0.5])
        who = {"algo": "sac", "stack": 1}
        fake_eval(run / "eval_test.json", "datasets/test", det, 10, [1.0] * 8, **who)
        fake_eval(run / "eval_test_sampled.json", "datasets/test", smp, 10, [2.0] * 9,
                  policy="stochastic", **who)  # fmt: skip
        fake_eval(run / "eval_train.json", "datasets/train", 0.5, 10, [3.0] * 5, **who)
        runs.append(load_run(run))
    table = compact_table(summarise(runs, []), "docs/results/x/table.md")
    assert "| SAC | 2 | 128 | 0.0 min | 70.00 ± 10.00 % | 80.00 ± 10.00 % | 1.00 s | 49.73 % |" in (
        table
    )
    assert "(sampled)" not in table and "n = " not in table and "train set" not in table
    assert table.count("\n| PPO |") == 1  # the paper's rows stay, empty
    assert "[the full table](docs/results/x/table.md)" in table
    full = markdown_table(summarise(runs, []))
    assert "| SAC (sampled) |" in full and "| train set |" in full
    rows = [line.split(" |")[0] for line in full.splitlines() if line.startswith("| SAC")]
    assert rows[:2] == ["| SAC", "| SAC (sampled)"]  # side by side, not after every row
    assert full.index("| SAC (sampled) |") < full.index("| SAC-STACK |")
    # a superseded candidate stays on the full page only
    short = compact_table(summarise(runs, []), "p.md", frozenset({"SAC"}))
    assert "\n| SAC |" not in short and "\n| PPO |" in short
    assert "superseded" in short and "superseded" not in table


def test_palette_gives_every_variant_of_a_report_its_own_colour() -> None:
    """Six variants whose names hashed to shared colours before: all distinct now, and the
    same variant gets the same colour in every plot of one report."""
    from rl.report_plots import palette

    names = {
        "scripted",
        "scripted-fast",
        "scripted-direct",
        "SAC+scripted-direct [bc_decay_steps=0, bc_weight=0.5, warmup_steps=50000]",
        "SAC+scripted-direct [bc_weight=0.0, warmup_steps=50000]",
        "SAC+scripted-fast [bc_decay_steps=0, bc_weight=0.5, warmup_steps=50000]",
    }
    colours = palette(names)
    assert set(colours) == names
    assert len({tuple(c) for c in colours.values()}) == len(names)
    assert palette(names) == colours
    # a screening page: 14 runs, each with its sampled row; the runs' curves stay distinct
    runs = {f"run-{i}" for i in range(14)}
    colours = palette(runs | {f"{v} (sampled)" for v in runs})
    assert len({tuple(colours[v]) for v in runs}) == 14
    assert all(colours[f"{v} (sampled)"] == colours[v] for v in runs)


def test_training_env_options_set_a_run_apart(tmp_path: Path) -> None:
    """A run trained with inside starts (or any training env option) is its own variant, so it
    is never averaged with the recipe's seeds; its evaluations, which name the policy only,
    follow it; an evaluation of another policy is still refused."""
    plain = fake_run(tmp_path / "plain", "sac", 1, 0, [8], [0.5])
    shaped = fake_run(tmp_path / "shaped", "sac", 1, 1, [8], [0.5])
    meta = json.loads((shaped / "config.json").read_text())
    meta["env_options"] = {
        "curriculum_steps": 10,
        "inside_starts": 0.25,
        "inside_starts_until": 0.1,
    }
    (shaped / "config.json").write_text(json.dumps(meta))
    for run in (plain, shaped):
        fake_eval(run / "eval_test.json", "test", 0.9, 10, [1.0] * 9, algo="sac", stack=1)
    a, b = load_run(plain), load_run(shaped)
    assert a.variant == "SAC"
    assert b.variant == "SAC inside_starts=0.25 inside_starts_until=0.1"
    assert [e.variant for e in b.evals] == [b.variant]
    summary = summarise([a, b], [])
    assert set(summary["curves"]) == {a.variant, b.variant}  # two rows, not one of 2 seeds
    fake_eval(shaped / "eval_test.json", "test", 0.9, 10, [1.0] * 9, algo="ppo", stack=1)
    with pytest.raises(ReportError, match=r"evaluates PPO, but the run .* is SAC"):
        load_run(shaped)
