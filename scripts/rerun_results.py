"""Run the stored results' commands again and regenerate the pages (a
maintainer's tool, for when the model, a rule or a shipped library changes).

    python scripts/rerun_results.py                       # every output, in the manifest's order
    python scripts/rerun_results.py --group realistic --group harsh
    python scripts/rerun_results.py --path traverse/line_flat-48v --dry-run

Each entry of ``results/manifest.toml`` is run with its own command, from
the checkout's root, with this interpreter's ``bin`` first on ``PATH`` (so
``bplir`` and ``python`` are this environment's).  The command writes into a
fresh directory beside the stored one; only when it finishes does that
directory take the stored one's place (the paths its summary names set to
the stored one's), so a failed or interrupted run leaves the stored output
as it was.  A study the command reads from its own output directory is
read from a copy.  Then ``scripts/results_pages.py`` writes the pages from
what is stored.  ``--dry-run`` prints the commands and touches nothing.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"


def entries(groups=(), paths=()) -> list[dict]:
    """The manifest's outputs, those of ``groups`` or ``paths`` if given."""
    items = tomllib.loads((RESULTS / "manifest.toml").read_text())["output"]
    if groups or paths:
        items = [i for i in items if i["group"] in groups or i["path"] in paths]
    return items


def out_dir(item: dict) -> str:
    """The directory the entry's command writes (relative to the root):
    its ``--out``, else the entry's own path (a benchmark's ``--json``)."""
    words = item["command"].split()
    return words[words.index("--out") + 1] if "--out" in words else f"results/{item['path']}"


def staged(item: dict, stage: Path, kept: Path) -> str:
    """The entry's command writing into ``stage`` instead of its output
    directory, reading a study it names inside that directory from
    ``kept`` (a copy made beforehand)."""
    target = out_dir(item)
    command = item["command"]
    words = command.split()
    for word in (w for opt, w in zip(words, words[1:]) if opt == "--study"):
        if word.startswith(target + "/"):
            copy = kept / Path(word).relative_to(target)
            copy.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / word, copy)
            command = command.replace(word, str(copy))
    if "--out" in command.split():
        return command.replace(f"--out {target}", f"--out {stage}")
    return command.replace(target + "/", f"{stage}/")   # a file written inside it


def finished(returncode: int, stage: Path) -> bool:
    """Whether a command finished its output: exit 0, or ``bplir
    commission``'s exit 1 for a robot that is not ready, with its report
    written."""
    return returncode == 0 or (returncode == 1 and (stage / "commission.json").is_file())


def _restamp(stage: Path, target: Path) -> None:
    """Name ``target`` where the run's text files (its summary, report,
    study) name ``stage``: both are under the root at the same depth, so
    paths relative to a file inside stay right."""
    old, new = (str(d.relative_to(ROOT)) for d in (stage, target))
    for f in stage.rglob("*"):
        if f.suffix in (".json", ".md", ".toml") and f.is_file():
            text = f.read_text()
            if old in text:
                f.write_text(text.replace(old, new))


def rerun(item: dict, dry_run: bool = False) -> float:
    """Run one entry; return its wall time (s).  The stored directory is
    replaced only when the command succeeded."""
    target = ROOT / out_dir(item)
    stage = target.parent / f".{target.name}.rerun"   # a sibling: the same depth
    with tempfile.TemporaryDirectory(prefix="bplir-rerun-") as kept:
        command = staged(item, stage.relative_to(ROOT), Path(kept))
        print(f"+ {command}", flush=True)
        if dry_run:
            return 0.0
        if stage.exists():   # a run that was stopped
            shutil.rmtree(stage)
        if "--out" not in item["command"].split():
            stage.mkdir()
        env = dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
        t0 = time.monotonic()
        try:
            rc = subprocess.run(["bash", "-c", command], cwd=ROOT, env=env).returncode
            if not finished(rc, stage):
                raise subprocess.CalledProcessError(rc, command)
        except BaseException:
            shutil.rmtree(stage, ignore_errors=True)
            raise
    for lock in stage.rglob(".lock"):
        lock.unlink()
    _restamp(stage, target)
    if target.exists():
        shutil.rmtree(target)
    stage.rename(target)
    return time.monotonic() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--group", action="append", default=[], help="only this group (repeatable)")
    ap.add_argument("--path", action="append", default=[], help="only this output (repeatable)")
    ap.add_argument("--dry-run", action="store_true", help="print the commands, run nothing")
    args = ap.parse_args(argv)
    items = entries(args.group, args.path)
    if not items:
        ap.error(f"no output in results/manifest.toml is in {args.group + args.path}")
    for item in items:
        try:
            wall = rerun(item, args.dry_run)
        except subprocess.CalledProcessError as exc:
            print(f"rerun_results: {item['path']}: the command failed (exit {exc.returncode}); "
                  "its stored output is kept", file=sys.stderr)
            return 1
        if not args.dry_run:
            print(f"{item['path']}: {wall:.0f} s", flush=True)
    if not args.dry_run:
        subprocess.run([sys.executable, str(ROOT / "scripts" / "results_pages.py")], check=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
