"""Build a pretrained pack: run every chapter into one artifact cache, then pack that cache with its manifest.

    python scripts/make_pack.py                         # every chapter, toy scale, seed 0 (`make artifacts`)
    python scripts/make_pack.py --seed 1 --notebooks 01_toy_world 02_diffusion_and_guidance
    python scripts/make_pack.py --no-run --cache DIR    # pack a cache a book run already filled

The pack is ``<out>/hoi_tutorial-<version>-<scale>-seed<seed>.zip`` (``hoi_tutorial.infra.make_pack``), with its
manifest beside it as ``.json`` and its SHA-256 printed: publish both with the release whose code built it (for a
release's own pack, ``python scripts/release.py --register <pack>`` adds the hash to
``hoi_tutorial.infra.pack.RELEASED_PACKS``). A chapter unpacks it with
``PRETRAINED = "<path>"`` or ``"<URL>#sha256=<hash>"`` (or ``True`` for the release's own), and only where the
installed code is the code that built each artifact.
"""
import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / "scripts"))
sys.path.insert(0, str(REPO_ROOT / "src"))

import bench  # noqa: E402  (scripts/bench.py: the chapters, run with papermill)

from hoi_tutorial.infra import make_pack  # noqa: E402
from hoi_tutorial.infra.pack import _ARTIFACT_FILE, _sha256_file, pack_name  # noqa: E402


# Put on the kernels' PYTHONPATH as sitecustomize.py: each kernel (and each worker process it spawns) appends to
# $HOI_ARTIFACT_LOG the name of every artifact file of $HOI_CACHE it opens or moves into place (an audit hook), so
# the manifest can say what each chapter loaded or built, and a chapter from the pack unpacks only that.
RECORDER = """import os
import sys

_LOG, _CACHE = os.environ.get("HOI_ARTIFACT_LOG"), os.environ.get("HOI_CACHE")


def _record(event, args):
    if event == "open":
        path = args[0]
    elif event == "os.rename":  # os.rename and os.replace: an artifact moved into place once built
        path = args[1]
    else:
        return
    if not isinstance(path, (str, os.PathLike)):
        return
    path = os.fspath(path)
    if path.endswith(".pt") and os.path.dirname(os.path.realpath(path)) == _CACHE:
        with open(_LOG, "a") as log:
            log.write(os.path.basename(path) + "\\n")


if _LOG and _CACHE:
    _CACHE = os.path.realpath(_CACHE)
    sys.addaudithook(_record)
"""


def used_artifacts(log: Path, cache: Path) -> list:
    """The artifact files of ``cache`` named in the recorder's ``log`` (each once)."""
    if not log.exists():
        return []
    names = {line.strip() for line in log.read_text().splitlines()}
    return sorted(n for n in names if _ARTIFACT_FILE.match(n) and (cache / n).is_file())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--notebooks", nargs="+", help="stems, file names or paths (default: every chapter)")
    parser.add_argument("--scale", default="toy")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cache", type=Path, default=REPO_ROOT / "build" / "artifacts" / "cache",
                        help="the artifact cache the chapters fill (kept: a second run resumes)")
    parser.add_argument("--out", type=Path, default=REPO_ROOT / "build" / "artifacts", help="where the pack goes")
    parser.add_argument("--no-run", action="store_true", help="pack --cache as it is, without running chapters")
    parser.add_argument("--timeout", type=int, default=1800, help="seconds a cell may run (as `make book`)")
    args = parser.parse_args(argv)

    args.cache.mkdir(parents=True, exist_ok=True)
    chapters = None
    if not args.no_run:
        recorder = Path(tempfile.mkdtemp(prefix="hoi_pack_recorder_"))
        (recorder / "sitecustomize.py").write_text(RECORDER)
        os.environ["PYTHONPATH"] = os.pathsep.join(
            p for p in (str(recorder), str(REPO_ROOT / "src"), os.environ.get("PYTHONPATH")) if p)
        chapters = {}
        os.environ.setdefault("MPLBACKEND", "Agg")
        os.environ["PYVISTA_OFF_SCREEN"] = "true"
        out_dir = args.out / "executed"
        out_dir.mkdir(parents=True, exist_ok=True)
        parameters = {"SCALE": args.scale, "SEED": args.seed}
        failed = []
        for path in bench.find_notebooks(args.notebooks):
            print(f"[artifacts] {path.name} ...", flush=True)
            log = recorder / f"{path.stem}.log"
            os.environ["HOI_ARTIFACT_LOG"] = str(log)
            seconds, error = bench.run_notebook(path, args.cache, out_dir, parameters, timeout=args.timeout)
            chapters[path.stem] = used_artifacts(log, args.cache.resolve())
            print(f"[artifacts] {path.name}: {seconds:.0f} s, {len(chapters[path.stem])} artifacts used"
                  + (f", FAILED ({error})" if error else ""), flush=True)
            if error:
                failed.append(path.stem)
        if failed:
            print(f"not packed: {len(failed)} chapter(s) failed ({', '.join(failed)}); their executed notebooks "
                  f"are in {out_dir}")
            return 1
    start = time.perf_counter()
    target = args.out / pack_name(args.scale, args.seed)
    manifest = make_pack(target, args.cache, scale=args.scale, seed=args.seed, chapters=chapters)
    target.chmod(0o644)  # to publish: readable by all, as a release asset
    (target.with_suffix(".json")).write_text(json.dumps(manifest, indent=1) + "\n")
    size = target.stat().st_size
    print(f"packed {len(manifest['files'])} artifacts ({sum(f['bytes'] for f in manifest['files']) / 1e6:.0f} MB "
          f"in the cache, {size / 1e6:.0f} MB packed) in {time.perf_counter() - start:.0f} s: {target}")
    print(f"sha256 {_sha256_file(target)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
