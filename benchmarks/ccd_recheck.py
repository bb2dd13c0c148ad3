"""The modules an `assetgen physics` report failed, checked again with libccd instead of
MuJoCo's own convex collision (`nativeccd` off), every other setting as the files carry it.

    assetgen physics test --json runs/physics_test.json
    python -m benchmarks.ccd_recheck runs/physics_test.json --out runs/physics_test_libccd.json

Prints, per module, the checks it still fails and the seconds of both runs; writes the
figures (JSON, saved after every module). docs/benchmarks.md quotes the result.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

from assetgen.dataset.reader import Dataset
from assetgen.physics.report import check_module, failures

FLAG = '<flag multiccd="enable"'


def recheck(report_path: Path, dataset: str | Path, out: Path) -> dict:
    from assetgen.core.atomic_file import write_json
    from assetgen.dataset.spec import resolve

    report = json.loads(report_path.read_text())
    root, _ = resolve(str(dataset))
    ds = Dataset(root)
    rows: dict[str, dict] = {}
    for mid in sorted(report["failed"]):
        xml = ds.paths(mid)["mjcf"].read_text()
        if FLAG not in xml:
            raise ValueError(f"module {mid}: its MJCF has no {FLAG!r}; not physics version 2")
        tmp = Path(tempfile.mkdtemp(prefix="ccd-"))
        try:
            path = tmp / "peg_in_hole.xml"
            path.write_text(xml.replace(FLAG, FLAG + ' nativeccd="disable"'))
            t = time.perf_counter()
            fig = check_module(path)
            fig["seconds"] = time.perf_counter() - t
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        rows[mid] = {
            "libccd": fig,
            "libccd_failed": failures(fig),
            "nativeccd_failed": report["failed"][mid],
            "nativeccd_seconds": report["modules"][mid]["seconds"],
        }
        print(mid, rows[mid]["libccd_failed"], f"{fig['seconds']:.1f} s", flush=True)
        write_json(out, rows, indent=1)
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("report", type=Path, help="an `assetgen physics --json` file")
    p.add_argument("--dataset", default="test", help="the dataset the report checked")
    p.add_argument("--out", type=Path, required=True, help="write the figures here (JSON)")
    args = p.parse_args(argv)
    rows = recheck(args.report, args.dataset, args.out)
    still = sum(1 for r in rows.values() if r["libccd_failed"])
    print(f"{len(rows)} modules checked again with libccd; {still} still fail a check")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
