"""pomc-batch: build many RGB-D panoramas into layered POMCs, on this machine or a Dask cluster.

    pomc-batch ITEMS -o OUT [--workers N] [--scheduler ADDRESS] [--report FILE] [build options]

ITEMS is a JSON-lines file, one object per panorama: ``colour`` and ``depth`` paths (relative to
the file), optional ``name`` (default: the colour file's directory and stem) and per-item build
options (``preset``, ``convention``, ``depth_scale`` …, as ``pomc build``'s with ``_``). Or ITEMS
is a glob of colour images and ``--depth-glob`` the matching depths (paired in sorted order).

Without ``--scheduler`` a ``dask.distributed.LocalCluster`` runs here (N worker processes, one
thread each: each build is itself parallel). With ``--scheduler tcp://host:8786`` the same code
submits to an existing cluster; every path must then be visible to the workers (shared storage).
Each item is written atomically into ``OUT/NAME/``; a rerun skips items already there; a failing
item is recorded with its code and message and the others go on; the exit status is 1 when any
item failed. See docs/batch.md.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence

from pomc import BUILD_OPTIONS

_DONE = "panorama.xml"


def load_items(spec: str, depth_glob: Optional[str] = None) -> List[Dict[str, Any]]:
    """The items of a JSON-lines file, or of a colour glob paired with ``depth_glob``."""
    if depth_glob is not None:
        colours, depths = sorted(glob.glob(spec)), sorted(glob.glob(depth_glob))
        if len(colours) != len(depths):
            raise SystemExit(f"pomc-batch: {len(colours)} colour and {len(depths)} depth files match the globs")
        return [{"colour": os.path.abspath(c), "depth": os.path.abspath(d)} for c, d in zip(colours, depths)]
    base = os.path.dirname(os.path.abspath(spec))
    items = []
    with open(spec, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            try:
                item = json.loads(line)
            except json.JSONDecodeError as e:
                raise SystemExit(f"pomc-batch: {spec}:{n}: not JSON ({e})") from None
            if not isinstance(item, dict) or "colour" not in item or "depth" not in item:
                raise SystemExit(f"pomc-batch: {spec}:{n}: an item needs \"colour\" and \"depth\"")
            for k in ("colour", "depth"):
                item[k] = os.path.join(base, item[k])
            items.append(item)
    return items


def item_name(item: Dict[str, Any]) -> str:
    if item.get("name"):
        return str(item["name"])
    colour = os.path.abspath(item["colour"])
    parent = os.path.basename(os.path.dirname(colour))
    stem = os.path.splitext(os.path.basename(colour))[0]
    return f"{parent}-{stem}" if parent else stem


def run_item(item: Dict[str, Any], out: str, options: Dict[str, Any]) -> Dict[str, Any]:
    """Build one item (on a worker); never raises."""
    name = item["name"]
    dest = os.path.join(out, name)
    result: Dict[str, Any] = {"name": name, "colour": item["colour"], "depth": item["depth"], "output": dest}
    if os.path.exists(os.path.join(dest, _DONE)):
        return {**result, "status": "skipped"}
    opts = {**options, **{k: v for k, v in item.items() if k not in ("colour", "depth", "name")}}
    t = time.perf_counter()
    # Imported here: run as `python -m pomc.batch`, this function reaches the workers by value.
    from pomc import PomcError, build_files

    try:
        summary = build_files(item["colour"], item["depth"], dest, **opts)
        result.update(status="ok", layers=len(summary["layers"]), stages=summary)
    except PomcError as e:
        result.update(status="failed", code=getattr(e, "code", "POMC_ERROR"), message=str(e))
    except BaseException as e:  # a worker must report, not die (a Rust panic is a BaseException)
        if isinstance(e, (KeyboardInterrupt, SystemExit)):
            raise
        code = getattr(e, "code", None)
        message = str(e) if isinstance(code, str) else f"{type(e).__name__}: {e}"
        result.update(status="failed", code=code if isinstance(code, str) else "BATCH_ITEM_FAILED", message=message)
    result["seconds"] = time.perf_counter() - t
    return result


class _Progress:
    """A one-line bar with the rate and ETA on stderr (quiet when stderr is not a terminal and
    ``force`` is off, except for a last line)."""

    def __init__(self, total: int, quiet: bool) -> None:
        self.total, self.done, self.failed, self.quiet = total, 0, 0, quiet
        self.start = time.perf_counter()
        self.tty = sys.stderr.isatty()

    def step(self, failed: bool) -> None:
        self.done += 1
        self.failed += failed
        if self.quiet or not self.tty:
            return
        elapsed = time.perf_counter() - self.start
        rate = self.done / elapsed if elapsed > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else float("inf")
        width = 30
        fill = int(width * self.done / max(self.total, 1))
        sys.stderr.write(
            f"\r[{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} "
            f"({self.failed} failed) {rate * 60:.1f}/min ETA {eta:.0f} s "
        )
        sys.stderr.flush()

    def finish(self) -> None:
        if not self.quiet and self.tty:
            sys.stderr.write("\n")


def _option_flags(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("build options (as pomc build; default: its defaults)")
    group.add_argument("--freedom-radius", type=float, default=0.5)
    group.add_argument("--convention", default="thesis", choices=["thesis", "blender", "openexr"])
    for name, default in BUILD_OPTIONS.items():
        flag = "--" + name.replace("_", "-")
        if isinstance(default, bool):
            group.add_argument(flag, action="store_true", default=None)
        elif name == "depth_bands":
            group.add_argument(flag, type=lambda s: [float(x) for x in s.split(",")], default=None)
        elif isinstance(default, float) or name in ("depth_scale", "depth_invalid"):
            group.add_argument(flag, type=float, default=None)
        else:
            group.add_argument(flag, default=None)


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="pomc-batch", description=__doc__.split("\n\n")[0])
    parser.add_argument("items", help="JSON-lines file of items, or a glob of colour images (with --depth-glob)")
    parser.add_argument("-o", "--output", required=True, help="output root: each item goes to OUTPUT/NAME/")
    parser.add_argument("--depth-glob", help="glob of depth images paired with ITEMS's colour glob")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="local worker processes")
    parser.add_argument("--scheduler", help="address of an existing Dask scheduler, e.g. tcp://host:8786")
    parser.add_argument("--report", help="write a JSON report here")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    _option_flags(parser)
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers must be at least 1")

    items = load_items(args.items, args.depth_glob)
    names = [item_name(i) for i in items]
    bad = [n for n in names if os.sep in n or "/" in n or n in ("", ".", "..") or n.startswith(".")]
    if bad:
        parser.error(f"item name {bad[0]!r} is not a plain directory name; names may not hold / or start with .")
    for item, name in zip(items, names):
        item["name"] = name
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        parser.error(f"item names repeat ({', '.join(dupes[:5])}); give each item a \"name\"")
    options: Dict[str, Any] = {"freedom_radius": args.freedom_radius, "convention": args.convention}
    for name in BUILD_OPTIONS:
        v = getattr(args, name)
        if v is not None:
            options[name] = v
    out = os.path.abspath(args.output)
    os.makedirs(out, exist_ok=True)

    from dask.distributed import Client, LocalCluster, as_completed

    start = time.perf_counter()
    if args.scheduler:
        client = Client(args.scheduler)
        cluster = None
    else:
        cluster = LocalCluster(
            n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None
        )
        client = Client(cluster)
    startup = time.perf_counter() - start
    results: List[Dict[str, Any]] = []
    bar = _Progress(len(items), args.quiet)
    try:
        futures = client.map(run_item, items, out=out, options=options, pure=False)
        by_key = {f.key: item for f, item in zip(futures, items)}
        for future in as_completed(futures):
            try:
                r = future.result()
            except Exception as e:  # the worker died (memory limit, crash): the item failed
                item = by_key[future.key]
                r = {
                    "name": item["name"], "colour": item["colour"], "depth": item["depth"],
                    "output": os.path.join(out, item["name"]), "status": "failed",
                    "code": "BATCH_WORKER_LOST", "message": f"{type(e).__name__}: {e}",
                }
            results.append(r)
            bar.step(r["status"] == "failed")
    finally:
        bar.finish()
        client.close()
        if cluster is not None:
            cluster.close()
    wall = time.perf_counter() - start
    counts = {s: sum(r["status"] == s for r in results) for s in ("ok", "skipped", "failed")}
    built_s = sum(r.get("seconds", 0.0) for r in results if r["status"] == "ok")
    report = {
        "items": sorted(results, key=lambda r: r["name"]),
        "counts": counts,
        "workers": None if args.scheduler else args.workers,
        "scheduler": args.scheduler,
        "wall_s": wall,
        "cluster_start_s": startup,
        "panoramas_per_minute": 60.0 * counts["ok"] / wall if wall > 0 else 0.0,
        "build_s": built_s,
    }
    if args.report:
        tmp = args.report + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(report, f, indent=2)
        os.replace(tmp, args.report)
    for r in report["items"]:
        if r["status"] == "failed":
            print(f"failed {r['name']}: error[{r['code']}] {r['message']}", file=sys.stderr)
    if not args.quiet:
        print(
            f"{counts['ok']} built, {counts['skipped']} already done, {counts['failed']} failed "
            f"in {wall:.1f} s ({report['panoramas_per_minute']:.1f}/min) -> {out}",
            file=sys.stderr,
        )
    return 1 if counts["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
