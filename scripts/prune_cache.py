"""Remove from the artifact cache what the installed code can no longer use (``hoi_tutorial.infra.prune_cache``).

    python scripts/prune_cache.py             # remove, and print what was removed (`make prune-cache`)
    python scripts/prune_cache.py --dry-run   # only print what would be removed

Removed: artifacts built by other code or of another format, or that cannot be read; temporaries and lock files
that killed runs left; downloaded packs of which the installed code would use nothing. The folder is the cache's
(``$HOI_CACHE`` when set); its other files and folders (the ledger's records) are left alone.
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from hoi_tutorial.infra import cache_dir, prune_cache  # noqa: E402


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except FileNotFoundError:  # removed meanwhile
        return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dry-run", action="store_true", help="only print what would be removed")
    args = parser.parse_args(argv)
    folder = cache_dir()
    sizes = {path: _size(path) for path in prune_cache(dry_run=True)}  # measured before they go
    pruned = sorted(sizes) if args.dry_run else prune_cache()
    verb = "would remove" if args.dry_run else "removed"
    for path in pruned:
        print(f"{verb} {path.relative_to(folder)}")
    total = sum(sizes.get(path, 0) for path in pruned)
    print(f"[cache] {folder}: {verb} {len(pruned)} file(s), {total / 1e6:.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
