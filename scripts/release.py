"""Cut a release: prepare its files, register its pack's hash, check that nothing is missing, then tag it.

A release ``X.Y.Z`` is named alike in pyproject.toml, ``hoi_tutorial.__version__``, CITATION.cff and CHANGELOG.md's
``## [X.Y.Z] — YYYY-MM-DD``; every chapter's set-up cell installs its tag ``vX.Y.Z``; and ``PRETRAINED = True``
finds its pack only through the SHA-256 in ``infra.pack.RELEASED_PACKS``. Between releases the version is
``X.Y.Z.devN`` (the next release's, PEP 440), whose pages install main and which has no pack. In order::

    python scripts/release.py --prepare 0.2.0    # the versions, CITATION.cff, CHANGELOG's heading, the set-up cells
    make artifacts                                # the release's pack, named by the version --prepare set
    python scripts/release.py --register build/artifacts/hoi_tutorial-0.2.0-toy-seed0.zip
    python scripts/release.py --check 0.2.0      # changes nothing; prints the git commands to tag and push
    python scripts/release.py --develop 0.3.0    # once tagged: main becomes 0.3.0.dev0
    python scripts/release.py --hash PACK.zip    # a pack's SHA-256, for PRETRAINED = "<url>#sha256=<hash>"

Nothing here runs git or downloads anything. ``--root`` names the checkout to work on (default: this one).
Exit status: 0 done (or ready), 1 ``--check`` found something missing, 2 a request refused (nothing changed).
"""
from __future__ import annotations

import argparse
import ast
import datetime
import hashlib
import json
import re
import sys
import zipfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / "scripts"))

import notebook_cells  # noqa: E402  (scripts/notebook_cells.py: the set-up cell and its stamp)

# The files a release touches, from a checkout's root.
PYPROJECT = Path("pyproject.toml")
INIT = Path("src") / "hoi_tutorial" / "__init__.py"
PACK_MODULE = Path("src") / "hoi_tutorial" / "infra" / "pack.py"
CITATION = Path("CITATION.cff")
CHANGELOG = Path("CHANGELOG.md")
NOTEBOOKS = Path("notebooks")
ARTIFACTS = Path("build") / "artifacts"  # where `make artifacts` puts a pack

RELEASE_VERSION = re.compile(r"^\d+\.\d+\.\d+$")
DEV_VERSION = re.compile(r"^(\d+\.\d+\.\d+)\.dev\d+$")
UNRELEASED = "## [Unreleased]"
RELEASE_HEADING = re.compile(r"^## \[(\d+\.\d+\.\d+)\] — (\d{4}-\d{2}-\d{2})$", flags=re.M)
# The name scripts/make_pack.py gives a pack (infra.pack.pack_name).
PACK_NAME = re.compile(r"^hoi_tutorial-(?P<version>[0-9A-Za-z.+]+)-(?P<scale>[a-z]+)-seed(?P<seed>\d+)\.zip$")
_MANIFEST_MAX_BYTES = 16 << 20  # as infra.pack: a pack's manifest.json is read whole


class ReleaseError(Exception):
    """A request that cannot be carried out as asked; the message says what was expected. Nothing was changed."""


def _release_tuple(version: str) -> tuple:
    return tuple(int(part) for part in version.split("."))


def _require_release(version: str, what: str) -> None:
    if not RELEASE_VERSION.match(version):
        raise ReleaseError(f"{what}: expected a release version X.Y.Z (a development version X.Y.Z.devN is never "
                           f"released), got {version!r}")


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


# ----------------------------------------------------------------------------------------------
# reading and rewriting the release's files (line by line, so that their formatting and comments stay)


def _read(root: Path, name: Path) -> str:
    path = root / name
    if not path.is_file():
        raise ReleaseError(f"{path}: expected this file in the checkout (--root {root})")
    return path.read_text(encoding="utf-8")


def _replace_once(text: str, pattern: str, replacement: str, where: str, flags: int = re.M) -> str:
    """``text`` with the one match of ``pattern`` replaced (refused where there is none or several: the file is not
    laid out as this script expects, and a guess could rewrite the wrong line)."""
    found = re.findall(pattern, text, flags=flags)
    if len(found) != 1:
        raise ReleaseError(f"{where}: expected one line matching {pattern!r}, found {len(found)}")
    return re.sub(pattern, lambda _: replacement, text, count=1, flags=flags)


def _pyproject_with_version(text: str, version: str) -> str:
    """pyproject.toml with ``[project] version`` set to ``version`` (the table's line, not another table's)."""
    table = re.search(r"^\[project\]\s*$(.*?)(?=^\[|\Z)", text, flags=re.M | re.S)
    if table is None:
        raise ReleaseError(f"{PYPROJECT}: expected a [project] table")
    body = _replace_once(table.group(1), r'^version = "[^"\n]*"$', f'version = "{version}"', f"{PYPROJECT} [project]")
    return text[:table.start(1)] + body + text[table.end(1):]


def init_version(root: Path) -> str:
    found = re.findall(r'^__version__ = "([^"\n]*)"$', _read(root, INIT), flags=re.M)
    if len(found) != 1:
        raise ReleaseError(f"{root / INIT}: expected one line __version__ = \"...\", found {len(found)}")
    return found[0]


def citation_field(root: Path, key: str) -> str:
    """A top-level field of CITATION.cff (``version``, ``date-released``), quotes removed."""
    found = re.findall(rf"^{re.escape(key)}:[ \t]*\"?([^\"\n]*?)\"?[ \t]*$", _read(root, CITATION), flags=re.M)
    if len(found) != 1:
        raise ReleaseError(f"{root / CITATION}: expected one top-level '{key}:' line, found {len(found)}")
    return found[0]


def changelog_state(text: str) -> tuple:
    """``(first '## ' heading, the Unreleased section's text or None, [(version, date), ...] newest first)``."""
    headings = re.findall(r"^## .*$", text, flags=re.M)
    unreleased = re.search(r"^## \[Unreleased\][ \t]*\n(.*?)(?=^## |\Z)", text, flags=re.M | re.S)
    return (headings[0] if headings else None, unreleased.group(1).strip() if unreleased else None,
            RELEASE_HEADING.findall(text))


def _notebooks(root: Path) -> list:
    found = sorted((root / NOTEBOOKS).glob("*.ipynb"))
    if not found:
        raise ReleaseError(f"{root / NOTEBOOKS}: expected the chapters' notebooks (*.ipynb)")
    return found


def _ready_to_stamp(root: Path) -> None:
    """Refuse now, before any file is written, what would make the re-stamp fail after the others were."""
    _notebooks(root)
    try:
        notebook_cells.repository_url(root)
        notebook_cells.render_functions(root)
    except (OSError, KeyError, TypeError, ValueError) as exc:
        raise ReleaseError(f"{root}: expected _config.yml's repository.url and {notebook_cells.RENDER_MODULE}'s "
                           f"__all__, which the set-up cells are stamped from ({type(exc).__name__}: {exc})") from None


def _with_version(root: Path, version: str) -> dict:
    """The new text of pyproject.toml and ``__init__.py`` with ``version``, by file."""
    return {PYPROJECT: _pyproject_with_version(_read(root, PYPROJECT), version),
            INIT: _replace_once(_read(root, INIT), r'^__version__ = "[^"\n]*"$', f'__version__ = "{version}"',
                                str(INIT))}


def _write(root: Path, texts: dict) -> None:
    for name, text in texts.items():
        (root / name).write_text(text, encoding="utf-8")
        print(f"wrote    {name}")


def _restamp(root: Path) -> list:
    """Re-stamp every chapter's set-up cell for the version pyproject.toml now holds; the paths it changed."""
    return [path for path in _notebooks(root) if notebook_cells.stamp(path, root=root)]


# ----------------------------------------------------------------------------------------------
# RELEASED_PACKS: a plain dict literal in infra/pack.py, rewritten in place


def _registry_node(source: str, where: Path) -> ast.AST:
    for node in ast.parse(source).body:
        target = node.target if isinstance(node, ast.AnnAssign) else (
            node.targets[0] if isinstance(node, ast.Assign) and len(node.targets) == 1 else None)
        if isinstance(target, ast.Name) and target.id == "RELEASED_PACKS":
            if not isinstance(node.value, ast.Dict):
                break
            return node
    raise ReleaseError(f"{where}: expected a module-level RELEASED_PACKS = {{...}} (a plain dict literal)")


def released_packs(root: Path) -> dict:
    """RELEASED_PACKS as pack.py states it (read, not imported: no torch needed, and a --root copy is read)."""
    source = _read(root, PACK_MODULE)
    try:
        packs = ast.literal_eval(_registry_node(source, root / PACK_MODULE).value)
    except ValueError:
        raise ReleaseError(f"{root / PACK_MODULE}: expected RELEASED_PACKS to hold only strings "
                           "(pack file name -> SHA-256)") from None
    return packs


def _registry_literal(packs: dict) -> str:
    if not packs:
        return "{}"
    entries = [f"    {json.dumps(name)}: {json.dumps(digest)},\n" for name, digest in sorted(packs.items())]
    return "{\n" + "".join(entries) + "}"


def write_released_packs(root: Path, packs: dict) -> None:
    """Rewrite RELEASED_PACKS' lines of pack.py as ``packs`` (sorted by name), the rest of the file as it was."""
    path = root / PACK_MODULE
    source = _read(root, PACK_MODULE)
    node = _registry_node(source, path)
    lines = source.splitlines(keepends=True)
    first, last = lines[node.lineno - 1], lines[node.end_lineno - 1]
    new = first[:node.value.col_offset] + _registry_literal(packs) + last[node.value.end_col_offset:]
    updated = "".join(lines[:node.lineno - 1]) + new + "".join(lines[node.end_lineno:])
    if ast.literal_eval(_registry_node(updated, path).value) != packs:  # never write a file that reads otherwise
        raise ReleaseError(f"{path}: rewriting RELEASED_PACKS went wrong; the file was left as it was")
    path.write_text(updated, encoding="utf-8")


def _pack_version(name: str):
    """The version a pack's file name states (``None``: not a pack's name)."""
    match = PACK_NAME.match(name)
    return match["version"] if match else None


def _pack_manifest(path: Path) -> dict:
    """The manifest of the pack ``path`` (our own file, built by make artifacts; read within the same cap)."""
    try:
        with zipfile.ZipFile(path) as archive:
            info = archive.getinfo("manifest.json")
            if info.file_size > _MANIFEST_MAX_BYTES:
                raise ReleaseError(f"{path}: expected a manifest.json of at most 16 MB")
            manifest = json.loads(archive.read(info))
    except (zipfile.BadZipFile, KeyError, ValueError) as exc:
        raise ReleaseError(f"{path}: expected a pack (a zip with manifest.json, from make artifacts): "
                           f"{type(exc).__name__}: {exc}") from None
    if not isinstance(manifest, dict) or manifest.get("package") != "hoi_tutorial":
        raise ReleaseError(f"{path}: expected a hoi_tutorial pack's manifest")
    return manifest


# ----------------------------------------------------------------------------------------------
# the modes


def _require_newer(version: str, released: list, mode: str) -> None:
    """Refuse a ``version`` that is not newer than CHANGELOG.md's newest release (``released[0]``, if any)."""
    if released and _release_tuple(version) <= _release_tuple(released[0][0]):
        raise ReleaseError(f"{mode} {version}: expected a version newer than CHANGELOG.md's newest release, "
                           f"{released[0][0]}")


def prepare(root: Path, version: str, date: str) -> int:
    """Make the checkout the release ``version`` of ``date``: pyproject.toml, ``__version__``, CITATION.cff (version,
    date-released), CHANGELOG.md (Unreleased becomes ``## [version] — date`` below a fresh empty Unreleased) and the
    set-up cells. Everything is checked before the first file is written."""
    _require_release(version, "--prepare")
    changelog = _read(root, CHANGELOG)
    first, unreleased, released = changelog_state(changelog)
    _require_newer(version, released, "--prepare")
    if first != UNRELEASED:
        raise ReleaseError(f"{CHANGELOG}: expected '{UNRELEASED}' as the first '## ' heading (what {version} "
                           f"releases), found {first!r}")
    if not unreleased:
        raise ReleaseError(f"{CHANGELOG}: '{UNRELEASED}' lists nothing: expected what {version} changes")
    texts = {
        **_with_version(root, version),
        CITATION: _replace_once(_replace_once(_read(root, CITATION), r"^version:.*$", f'version: "{version}"',
                                              str(CITATION)),
                                r"^date-released:.*$", f'date-released: "{date}"', str(CITATION)),
        CHANGELOG: _replace_once(changelog, r"^## \[Unreleased\][ \t]*$", f"{UNRELEASED}\n\n## [{version}] — {date}",
                                 str(CHANGELOG)),
    }
    _ready_to_stamp(root)
    _write(root, texts)
    stamped = _restamp(root)
    print(f"stamped  {len(stamped)} notebook(s): their set-up cells install v{version}")
    print(f"\nnext: commit; `make artifacts` builds the pack hoi_tutorial-{version}-toy-seed0.zip; "
          f"`python scripts/release.py --register <pack>`; `python scripts/release.py --check {version}`")
    return 0


def develop(root: Path, next_version: str) -> int:
    """Start the code after a release: the version becomes ``next_version.dev0`` (its pages install main, and
    ``PRETRAINED = True`` is refused), CHANGELOG.md gets an empty Unreleased on top where it has none; CITATION.cff
    keeps citing the release."""
    _require_release(next_version, "--develop")
    changelog = _read(root, CHANGELOG)
    first, _, released = changelog_state(changelog)
    _require_newer(next_version, released, "--develop")
    version = f"{next_version}.dev0"
    texts = _with_version(root, version)
    if first != UNRELEASED:
        heading = re.search(r"^## ", changelog, flags=re.M)
        at = heading.start() if heading else len(changelog)
        texts[CHANGELOG] = changelog[:at] + f"{UNRELEASED}\n\n" + changelog[at:]
    _ready_to_stamp(root)
    _write(root, texts)
    stamped = _restamp(root)
    print(f"stamped  {len(stamped)} notebook(s): their set-up cells install {notebook_cells.DEVELOPMENT_BRANCH}")
    print(f"\nnext: commit ('Start {version}'); list each change under '{UNRELEASED}' in {CHANGELOG}")
    return 0


def register(root: Path, pack: Path) -> int:
    """Write the SHA-256 of the release's pack ``pack`` into RELEASED_PACKS, after checking that it is a pack of the
    version pyproject.toml holds (a release), under the name make artifacts gave it, whose manifest says the same."""
    if not pack.is_file():
        raise ReleaseError(f"--register: expected a pack file, {pack} is not a file")
    name = PACK_NAME.match(pack.name)
    if name is None:
        raise ReleaseError(f"--register: expected a pack named hoi_tutorial-<version>-<scale>-seed<seed>.zip "
                           f"(as make artifacts names it), got {pack.name!r}")
    version = notebook_cells.package_version(root)
    _require_release(version, f"{PYPROJECT}'s version (run --prepare first)")
    if name["version"] != version:
        raise ReleaseError(f"--register: expected a pack of {version} (pyproject.toml's version), {pack.name} is of "
                           f"{name['version']}: build it with `make artifacts` after --prepare")
    manifest = _pack_manifest(pack)
    claimed = (manifest.get("version"), manifest.get("scale"), manifest.get("seed"))
    if claimed != (version, name["scale"], int(name["seed"])):
        raise ReleaseError(f"{pack}: its manifest says version, scale, seed = {claimed}; expected what its name says, "
                           f"{(version, name['scale'], int(name['seed']))}")
    digest = sha256_of(pack)
    packs = released_packs(root)
    if packs.get(pack.name) == digest:
        print(f"ok       {pack.name} is registered already: {digest}")
        return 0
    packs[pack.name] = digest
    write_released_packs(root, packs)
    print(f"wrote    {PACK_MODULE}: RELEASED_PACKS[{pack.name!r}] = {digest!r}")
    return 0


def check(root: Path, version: str) -> int:
    """Print each thing the release ``version`` needs as ok or missing, changing nothing; with nothing missing, the
    git commands that tag and publish it (printed, not run). Returns 1 when anything is missing."""
    items = []

    def item(ok: bool, text: str) -> None:
        items.append(ok)
        print(f"{'ok' if ok else 'missing':8} {text}")

    is_release = bool(RELEASE_VERSION.match(version))
    item(is_release, f"{version} is a release version X.Y.Z" if is_release else
         f"{version} is not a release version X.Y.Z (a development version X.Y.Z.devN is never tagged)")
    project = notebook_cells.package_version(root)
    item(project == version, f"{PYPROJECT}: version = \"{project}\"" + ("" if project == version else
         f", expected \"{version}\" (python scripts/release.py --prepare {version})"))
    in_code = init_version(root)
    item(in_code == version, f"{INIT}: __version__ = \"{in_code}\"" + ("" if in_code == version else
         f", expected \"{version}\""))

    first, unreleased, released = changelog_state(_read(root, CHANGELOG))
    dates = dict(released)
    date = dates.get(version)
    try:
        dated = date is not None and bool(datetime.date.fromisoformat(date))
    except ValueError:
        dated = False
    newest = released[0][0] if released else None
    item(dated and newest == version, f"{CHANGELOG}: '## [{version}] — {date}', its newest release" if dated and
         newest == version else f"{CHANGELOG}: expected '## [{version}] — YYYY-MM-DD' (a date that exists) as the "
         f"newest release heading; found {'none' if date is None else repr(date)}, newest {newest}")
    item(not unreleased, f"{CHANGELOG}: nothing listed under '{UNRELEASED}'" if not unreleased else
         f"{CHANGELOG}: '{UNRELEASED}' lists changes: expected them under '## [{version}] — <date>' "
         f"(--prepare moves them)")

    cited, cited_date = citation_field(root, "version"), citation_field(root, "date-released")
    expected_date = f"\"{date}\", the date of CHANGELOG's heading" if date else "the date of CHANGELOG's heading (none)"
    item(cited == version and date is not None and cited_date == date,
         f"{CITATION}: version \"{cited}\", date-released \"{cited_date}\"" + (
             "" if cited == version and cited_date == date else f", expected \"{version}\" and {expected_date}"))

    notebooks = _notebooks(root)
    stale = [p.name for p in notebooks if notebook_cells.stamp(p, check=True, root=root)]
    elsewhere = [p.name for p in notebooks if f'@v{version}"' not in _setup_cell_source(p)]
    item(not stale and not elsewhere, f"{NOTEBOOKS}: the set-up cells of {len(notebooks)} notebook(s) install "
         f"@v{version}" if not stale and not elsewhere else f"{NOTEBOOKS}: expected set-up cells that install "
         f"@v{version} (--prepare stamps them, as does python scripts/notebook_cells.py notebooks/*.ipynb once "
         f"pyproject.toml says {version}); stale: {', '.join(stale) or 'none'}; installing another version: "
         f"{', '.join(elsewhere) or 'none'}")

    packs = released_packs(root)
    built = sorted((root / ARTIFACTS).glob(f"hoi_tutorial-{version}-*-seed*.zip"))
    for pack in built:
        listed, digest, where = packs.get(pack.name), sha256_of(pack), ARTIFACTS / pack.name
        if listed == digest:
            item(True, f"{PACK_MODULE}: RELEASED_PACKS lists {where}'s SHA-256 {digest}")
        else:
            item(False, f"{PACK_MODULE}: RELEASED_PACKS[{pack.name!r}] is {listed!r}, expected {where}'s SHA-256 "
                 f"{digest} (python scripts/release.py --register {where})")
    registered = sorted(name for name in packs if _pack_version(name) == version)
    if not built:
        item(True, f"{ARTIFACTS}: no pack of {version} to compare; RELEASED_PACKS lists "
             + (", ".join(registered) if registered else f"none, so PRETRAINED = True is refused for {version}"))

    missing = items.count(False)
    if missing:
        print(f"\nnot ready: {missing} item(s) missing; nothing was changed")
        return 1
    tag = f"v{version}"
    print(f"\nready to release {version}. With the release committed, tag and publish it (printed, not run):\n"
          f"    git tag -a {tag} -m \"hoi_tutorial {version}\"\n"
          f"    git push origin {tag}")
    if registered:  # where infra.pack.release_pack_url looks for them
        print(f"then attach to the GitHub release {tag} each pack RELEASED_PACKS lists and its manifest; "
              "PRETRAINED = True downloads the pack from the address after the arrow:")
        for name in registered:
            print(f"    {ARTIFACTS / name}, {ARTIFACTS / Path(name).with_suffix('.json')} -> "
                  f"{notebook_cells.repository_url(root)}/releases/download/{tag}/{name}")
    major, minor, _ = _release_tuple(version)
    print(f"and start the next version on main: python scripts/release.py --develop {major}.{minor + 1}.0")
    return 0


def _setup_cell_source(path: Path) -> str:
    import nbformat

    cells = nbformat.read(path, as_version=4).cells
    return cells[0].source if cells else ""


def show_hash(pack: Path) -> int:
    """Print a pack's SHA-256 and the ``PRETRAINED`` value a class hands out with its URL."""
    if not pack.is_file():
        raise ReleaseError(f"--hash: expected a pack file, {pack} is not a file")
    digest = sha256_of(pack)
    print(f"sha256 {digest}  {pack.name}")
    print(f'PRETRAINED = "https://<where you host it>/{pack.name}#sha256={digest}"')
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", metavar="VERSION", help="report what the release VERSION needs (changes nothing)")
    mode.add_argument("--prepare", metavar="VERSION", help="make the checkout the release VERSION")
    mode.add_argument("--register", metavar="PACK", type=Path, help="write a release pack's SHA-256 to RELEASED_PACKS")
    mode.add_argument("--develop", metavar="NEXT", help="after a release: the version becomes NEXT.dev0")
    mode.add_argument("--hash", metavar="PACK", type=Path, help="print a pack's SHA-256")
    parser.add_argument("--date", help="--prepare's release date, YYYY-MM-DD (default: today)")
    parser.add_argument("--root", type=Path, default=REPO_ROOT, help="the checkout to work on (default: this one)")
    args = parser.parse_args(argv)
    root = args.root.resolve()
    try:
        if args.date is not None and args.prepare is None:
            raise ReleaseError("--date: expected only with --prepare")
        if args.prepare is not None:
            date = args.date or datetime.date.today().isoformat()
            try:
                datetime.date.fromisoformat(date)
            except ValueError:
                raise ReleaseError(f"--date: expected a date YYYY-MM-DD that exists, got {date!r}") from None
            return prepare(root, args.prepare, date)
        if args.develop is not None:
            return develop(root, args.develop)
        if args.register is not None:
            return register(root, args.register)
        if args.hash is not None:
            return show_hash(args.hash)
        return check(root, args.check)
    except ReleaseError as exc:
        print(f"release.py: refused: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
