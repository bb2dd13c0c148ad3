"""`python -m benchmarks.by_param`: an evaluation's success split by module parameter."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmarks.by_param import by_param, groups, main, module_params


def test_groups_are_quartiles_or_values() -> None:
    g = groups(np.arange(12.0))
    assert [(lo, hi, int(m.sum())) for lo, hi, m in g] == [
        (0.0, 2.75, 3), (2.75, 5.5, 3), (5.5, 8.25, 3), (8.25, 11.0, 3)]  # fmt: skip
    assert sum(int(m.sum()) for *_, m in g) == 12  # every value in one group only
    g = groups(np.array([3.0, 4.0, 3.0, 6.0]))
    assert [(lo, int(m.sum())) for lo, _, m in g] == [(3.0, 2), (4.0, 1), (6.0, 1)]
    # n_vertices' seven values (3-8 and 32): each its own group, triangles apart from squares
    sides = np.array([3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 32.0, 3.0])
    assert [(lo, int(m.sum())) for lo, _, m in groups(sides)][:2] == [(3.0, 2), (4.0, 1)]


def test_failures_gather_on_the_parameter_that_causes_them(tiny_dataset, tmp_path, capsys):
    params = module_params(tiny_dataset)
    tilt = {m: p["hole_tilt"] for m, p in params.items()}
    assert all(t == pytest.approx(np.hypot(params[m]["hole_tilt_x"], params[m]["hole_tilt_y"]))
               for m, t in tilt.items())  # fmt: skip
    cut = float(np.median(list(tilt.values())))
    per_module = {m: float(t <= cut) for m, t in tilt.items()}  # the tilted holes fail
    rows = by_param(per_module, params, ["hole_tilt"])["hole_tilt"]
    assert rows[0]["success"] == 1.0 and rows[-1]["success"] == 0.0
    assert sum(r["modules"] for r in rows) == len(params)
    out = tmp_path / "eval.json"
    out.write_text(json.dumps({"per_module": per_module, "dataset_folder": str(tiny_dataset)}))
    assert main([str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    (line,) = [x for x in lines if x.split()[0] == "hole_tilt"]
    assert "100.0 %" in line and "  0.0 %" in line
    assert "100.0 %" in lines[2] and "  0.0 %" in lines[2]  # the largest spread comes first
    with pytest.raises(SystemExit):
        main([str(out), "--param", "no_such"])
    assert "--param 'no_such': the modules' parameters are" in capsys.readouterr().err
    with pytest.raises(ValueError, match="not in the dataset"):
        by_param({"999999": 1.0}, params, None)


def test_seeds_pool_and_where_keeps_a_family(tiny_dataset, tmp_path, capsys) -> None:
    params = module_params(tiny_dataset)
    ids = sorted(params)
    tilt = {m: params[m]["hole_tilt"] for m in ids}
    cut = float(np.median(list(tilt.values())))
    files = []
    for seed, fail in enumerate((0.0, 0.5)):  # the tilted holes: 0 and 0.5, pooled 0.25
        f = tmp_path / f"s{seed}.json"
        per_module = {m: 1.0 if tilt[m] <= cut else fail for m in ids}
        f.write_text(json.dumps({"per_module": per_module, "dataset_folder": str(tiny_dataset)}))
        files.append(str(f))
    assert main([*files, "--param", "hole_tilt"]) == 0
    out = capsys.readouterr().out
    assert "2 files pooled" in out and " 25.0 %" in out
    # only the upright holes: every one succeeds
    assert main([*files, "--where", f"hole_tilt=0:{cut}", "--param", "hole_tilt"]) == 0
    out = capsys.readouterr().out
    kept = sum(t <= cut for t in tilt.values())
    assert f"{kept} modules where hole_tilt=0:{cut}, success 100.0 %" in out
    for bad, says in (("no_such=1", "NAME one of the modules' parameters"),
                      ("hole_tilt=flat", "is not a number"),
                      ("hole_tilt=1:0", "LOW is above HIGH"),
                      ("hole_tilt=9:10", "no evaluated module matches")):  # fmt: skip
        with pytest.raises(SystemExit):
            main([*files, "--where", bad])
        assert says in capsys.readouterr().err, bad
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"per_module": {ids[0]: 1.0}, "dataset_folder": "x"}))
    with pytest.raises(SystemExit):
        main([files[0], str(other)])
    assert "other modules than" in capsys.readouterr().err
