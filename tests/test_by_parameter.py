"""`python -m benchmarks.by_parameter`: success and share of misses by a Table I parameter."""

from __future__ import annotations

import json

import pytest

from benchmarks.by_parameter import groups, main, table


def test_few_values_group_by_value_and_many_into_equal_quantiles() -> None:
    sides = {"a": 3.0, "b": 4.0, "c": 3.0, "d": 32.0}
    assert groups(sides, 4) == [("3", ["a", "c"]), ("4", ["b"]), ("32", ["d"])]
    size = {f"m{i}": float(i) for i in range(12)}  # 12 distinct values: binned
    got = groups(size, 3)
    assert [len(ids) for _, ids in got] == [4, 4, 4]
    assert got[0] == ("0 – 3", ["m0", "m1", "m2", "m3"]) and got[2][0] == "8 – 11"


def test_the_table_gives_each_groups_success_and_its_share_of_the_misses() -> None:
    params = {"a": {"n": 3.0}, "b": {"n": 3.0}, "c": {"n": 6.0}, "d": {"n": 6.0}}
    rates = {"a": 0.5, "b": 0.1, "c": 1.0, "d": 0.8}  # misses: 0.5 + 0.9 = 1.4 and 0.2
    lines = table("n", params, [("run", rates)], bins=4).splitlines()
    assert lines[2] == "| 3 | 2 | 30.0 % | 88 % |"
    assert lines[3] == "| 6 | 2 | 90.0 % | 12 % |"
    perfect = table("n", params, [("all", dict.fromkeys(rates, 1.0))], 4).splitlines()
    assert perfect[2] == "| 3 | 2 | 100.0 % | – |"  # no misses to share


def _eval_file(path, rates, folder) -> None:
    path.write_text(json.dumps({"per_module": rates, "dataset_folder": str(folder)}))


def test_it_reads_the_modules_parameters_from_the_files_dataset(tiny_dataset, tmp_path, capsys):
    from assetgen.dataset.reader import Dataset

    ds = Dataset(tiny_dataset)
    ids = ds.ids
    rates = {mid: (0.0 if i == 0 else 1.0) for i, mid in enumerate(ids)}
    (tmp_path / "run").mkdir()
    _eval_file(tmp_path / "run/eval_test.json", rates, tiny_dataset)
    assert main([str(tmp_path / "run/eval_test.json"), "--param", "n_vertices"]) == 0
    out = capsys.readouterr().out.splitlines()
    sides = ds.module_json(ids[0])["params"]["n_vertices"]
    row = next(line for line in out if line.startswith(f"| {sides:g} |"))
    n = sum(ds.module_json(m)["params"]["n_vertices"] == sides for m in ids)
    assert row == f"| {sides:g} | {n} | {100 * (n - 1) / n:.1f} % | 100 % |"  # all the misses
    assert out[0].startswith("| n_vertices | modules | run: success | misses |")


def test_bad_input_names_what_is_wrong(tiny_dataset, tmp_path, capsys) -> None:
    from assetgen.dataset.reader import Dataset

    ids = Dataset(tiny_dataset).ids
    good, other, bare = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    _eval_file(good, dict.fromkeys(ids, 1.0), tiny_dataset)
    _eval_file(other, dict.fromkeys(ids[:2], 1.0), tiny_dataset)
    bare.write_text(json.dumps({"success_rate": 1.0}))
    cases = [
        ([str(good), str(other)], "covers other modules"),
        ([str(bare)], "no per_module success rates"),
        ([str(good), "--param", "colour"], "--param colour: not a parameter"),
        ([str(good), "--dataset", str(tmp_path)], "is not here"),
        ([str(good), "--bins", "0"], "--bins 0"),
    ]
    for argv, message in cases:
        with pytest.raises(SystemExit):
            main(argv)
        assert message in capsys.readouterr().err
