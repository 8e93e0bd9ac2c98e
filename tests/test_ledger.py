"""The results ledger: the claim registry, the records chapters write, and the page built from them."""
import json
import re
from pathlib import Path

import nbformat
import numpy as np
import pytest
import yaml

from hoi_tutorial import intervals, ledger
from hoi_tutorial.ledger import claims as claims_module
from hoi_tutorial.nifty import paper_numbers as nifty_numbers

REPO_ROOT = Path(__file__).resolve().parents[1]
PAGE = REPO_ROOT / "reference" / "ledger.ipynb"
RECORD_CALL = re.compile(r"ledger\.record\(\s*[\"']([a-z0-9._]+)[\"']")
REGENERATED = [c for c in ledger.CLAIMS if c.chapter is not None]


def _recorded_keys():
    found = {}
    for path in sorted((REPO_ROOT / "notebooks").glob("*.ipynb")):
        source = "\n".join(c.source for c in nbformat.read(path, as_version=4).cells if c.cell_type == "code")
        for key in RECORD_CALL.findall(source):
            found.setdefault(key, []).append(path.stem)
    return found


def _record_all(claims=REGENERATED, seed=0):
    return [ledger.record(c.key, seed=seed, scale="toy", ours=f"test text for {c.key}",
                          checks={"first direction": True, "second direction": c.key.endswith("s")})
            for c in claims]


# ------------------------------------------------------------------------------------------------ registry


def test_every_paper_has_claims_and_every_chapter_exists():
    assert {c.paper for c in ledger.CLAIMS} == set(ledger.PAPERS)
    for c in REGENERATED:
        assert (REPO_ROOT / "notebooks" / f"{c.chapter}.ipynb").is_file(), c.key
        assert c.statement and c.paper_numbers and c.source


def test_each_chapter_records_exactly_its_claims():
    found = _recorded_keys()
    registered = {c.key: c.chapter for c in REGENERATED}
    assert set(found) == set(registered), (
        f"recorded but not registered: {sorted(set(found) - set(registered))}; "
        f"registered but recorded by no chapter: {sorted(set(registered) - set(found))}")
    for key, chapters in found.items():
        assert chapters == [registered[key]], f"{key} is recorded by {chapters}, registered to {registered[key]}"


def test_paper_numbers_are_quoted_from_the_transcriptions():
    reach = ledger.claim("nifty.t1.reach").paper_numbers
    table = nifty_numbers.TABLE1
    for action in ("sit", "lift"):
        cells = " / ".join(f"{table[action][m]['% D2O ≤ 2cm ↑']:.1f}" for m in nifty_numbers.TABLE1_METHODS)
        assert f"{action} {cells}" in reach
    # A column printed with two decimals keeps them (0.00, 65.40); an int stays an int; ∞ is written as such.
    assert "99.60" in ledger.claim("nifty.t4.samples").paper_numbers
    assert "w/o reshaping 100 /" in ledger.claim("choice.t3.diffusion_policy").paper_numbers
    assert "∞ / ∞ / 17.06" in ledger.claim("samp.t2.execution_time").paper_numbers
    assert claims_module._text(0.0, 2) == "0.00" and claims_module._text(11.7) == "11.7"


def test_claim_validation_and_lookup():
    with pytest.raises(KeyError, match="no claim 'nifty.t99'"):
        ledger.claim("nifty.t99")
    with pytest.raises(ValueError, match="paper"):
        ledger.Claim("xyz.a", "XYZ", "Table 1", "s", "n", "01_toy_world")
    with pytest.raises(ValueError, match="planned"):
        ledger.Claim("samp.a", "SAMP", "Table 1", "s", "n", None)
    with pytest.raises(ValueError, match="key"):
        ledger.Claim("SAMP.A", "SAMP", "Table 1", "s", "n", "01_toy_world")


# ------------------------------------------------------------------------------------------------- records


@pytest.mark.parametrize("checks, status", [
    ({"a": True, "b": True}, "reproduced"), ({"a": True, "b": False}, "partly"),
    ({"a": False}, "not reproduced"), (None, "shown"), ({}, "shown"),
    ({"a": "held", "b": True}, "reproduced"), ({"a": "inconclusive"}, "inconclusive"),
    ({"a": "inconclusive", "b": "inconclusive"}, "inconclusive"), ({"a": "held", "b": "inconclusive"}, "partly"),
    ({"a": "not held", "b": "inconclusive"}, "not reproduced")])
def test_status_follows_from_the_checks(checks, status):
    assert ledger.status_of(checks) == status


def test_an_interval_that_straddles_zero_is_recorded_inconclusive(tmp_cache):
    # A direction measured with a paired interval: a difference that noise alone could give is neither
    # reproduced nor refuted.
    rng = np.random.default_rng(0)
    a = rng.normal(0, 1, 24)
    noise_only = intervals.paired_difference(a + rng.normal(0, 0.1, 24), a)   # no effect, only noise
    clear = intervals.paired_difference(a + 1.0, a)
    made = ledger.record("nifty.t4.samples", seed=0, scale="toy", ours="text",
                         checks={"falls (noise)": noise_only.verdict("above"), "falls (clear)": clear.verdict("above")})
    assert noise_only.verdict("above") == "inconclusive"
    assert made.checks == (("falls (noise)", "inconclusive"), ("falls (clear)", "held"))
    assert made.status == "partly" and made.status_text() == "partly (1 of 2; 1 inconclusive)"
    alone = ledger.record("nifty.t4.samples", seed=1, scale="toy", ours="text",
                          checks={"falls (noise)": noise_only.verdict("above")})
    assert alone.status == "inconclusive" and alone.status_text() == "inconclusive (0 of 1; 1 inconclusive)"
    assert ledger.load_record("nifty.t4.samples", 1, "toy") == alone
    assert "falls (noise): inconclusive" in ledger.chapter_summary([alone]).data["checked"][0]


def test_record_round_trip(tmp_cache):
    made = ledger.record("nifty.t4.samples", seed=2, scale="toy", ours="skeleton distance 5.7 -> 4.8 m",
                         checks={"falls from N = 1 to 10": np.bool_(True), "reach rises": False})
    assert made.status == "partly" and made.status_text() == "partly (1 of 2)"
    assert made.chapter == "09_nifty_ablations_sampling"
    assert made.chapter_digest == ledger.chapter_digest(made.chapter) and made.chapter_digest is not None
    assert ledger.record_path("nifty.t4.samples", 2, "toy").is_file()
    assert ledger.load_record("nifty.t4.samples", 2, "toy") == made
    assert ledger.load_record("nifty.t4.samples", 0, "toy") is None


def test_record_rejects_bad_input(tmp_cache):
    good = dict(seed=0, scale="toy", ours="text")
    with pytest.raises(KeyError, match="expected one of"):
        ledger.record("nifty.unknown", **good)
    with pytest.raises(TypeError, match="computed bool"):
        ledger.record("nifty.t4.samples", checks={"falls": 0.3}, **good)
    with pytest.raises(TypeError, match="verdict"):
        ledger.record("nifty.t4.samples", checks={"falls": "yes"}, **good)
    with pytest.raises(ValueError, match="name in words"):
        ledger.record("nifty.t4.samples", checks={"": True}, **good)
    with pytest.raises(ValueError, match="ours"):
        ledger.record("nifty.t4.samples", seed=0, scale="toy", ours="  ")
    with pytest.raises(ValueError, match="scale"):
        ledger.record("nifty.t4.samples", seed=0, scale="huge", ours="text")
    with pytest.raises(TypeError, match="seed"):
        ledger.record("nifty.t4.samples", seed=0.5, scale="toy", ours="text")


def test_library_digest_ignores_the_ledger_and_follows_the_library():
    files = {p.relative_to(REPO_ROOT / "src").as_posix() for p in (REPO_ROOT / "src" / "hoi_tutorial").rglob("*.py")}
    assert "hoi_tutorial/ledger/records.py" in files
    assert ledger.library_digest() == ledger.library_digest()
    assert len(ledger.library_digest()) == 64


# -------------------------------------------------------------------------------------------------- ledger


def test_ledger_rows_from_complete_records(tmp_cache):
    _record_all()
    _record_all(REGENERATED[:3], seed=1)
    planned = ledger.Claim("samp.planned_example", "SAMP", "Table 9", "a claim no chapter regenerates yet", "1.0",
                           None, planned="its model is not built")
    claims = ledger.CLAIMS + (planned,)
    rows = ledger.ledger_rows(seed=0, scale="toy", claims=claims)
    assert [r["claim"].key for r in rows] == [c.key for c in claims]
    assert rows[-1]["status"] == "planned" and rows[-1]["record"] is None
    assert set(rows[0]["other_seeds"]) == {1} and not rows[-2]["other_seeds"]
    table = ledger.summary(rows)
    assert int(table.loc["all", "claims"]) == len(claims)
    assert int(table.loc["all", "planned"]) == 1 and int(table.loc["SAMP", "planned"]) == 1
    assert "its model is not built" in ledger.markdown_table(rows, "SAMP")
    rows = rows[:-1]
    markdown = ledger.markdown_table(rows, "NIFTY")
    assert markdown.count("\n") == 1 + sum(c.paper == "NIFTY" for c in ledger.CLAIMS)
    assert "test text for nifty.t1.reach" in markdown and "(../notebooks/06_evaluating_nifty.ipynb)" in markdown


def test_a_missing_record_fails_loudly(tmp_cache):
    _record_all()
    missing = REGENERATED[5]
    ledger.record_path(missing.key, 0, "toy").unlink()
    with pytest.raises(ledger.LedgerError) as error:
        ledger.ledger_rows(seed=0, scale="toy")
    message = str(error.value)
    assert missing.key in message and f"notebooks/{missing.chapter}.ipynb" in message and "1 of" in message


def test_a_stale_record_fails_loudly(tmp_cache):
    _record_all()
    stale = REGENERATED[0]
    path = ledger.record_path(stale.key, 0, "toy")
    payload = json.loads(path.read_text())
    payload["chapter_digest"] = "0" * 64
    path.write_text(json.dumps(payload))
    with pytest.raises(ledger.LedgerError, match=re.escape(stale.key) + r".*chapter's code changed"):
        ledger.ledger_rows(seed=0, scale="toy")
    payload["chapter_digest"] = ledger.chapter_digest(stale.chapter)
    payload["library_digest"] = "1" * 64
    path.write_text(json.dumps(payload))
    with pytest.raises(ledger.LedgerError, match="library's source changed"):
        ledger.ledger_rows(seed=0, scale="toy")


# ---------------------------------------------------------------------------------------------------- page


def _execute_page(tmp_path):
    from nbclient import NotebookClient

    nb = nbformat.read(PAGE, as_version=4)
    # generous limits: CI runs the tests at the lowest priority beside the book build, where a kernel may wait minutes
    NotebookClient(nb, timeout=1800, startup_timeout=1800, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    return nb


def test_the_page_is_built_from_the_records_and_breaks_without_one(tmp_cache, tmp_path):
    from nbclient.exceptions import CellExecutionError

    _record_all()
    nb = _execute_page(tmp_path)
    shown = "\n".join(out.get("data", {}).get("text/markdown", "") for c in nb.cells if c.cell_type == "code"
                      for out in c.get("outputs", []))
    for c in REGENERATED:
        assert f"test text for {c.key}" in shown
    # On purpose: one chapter's record is gone. The page must stop and name the claim and the chapter.
    missing = next(c for c in REGENERATED if c.paper == "CHOICE")
    ledger.record_path(missing.key, 0, "toy").unlink()
    with pytest.raises(CellExecutionError) as error:
        _execute_page(tmp_path)
    assert "LedgerError" in str(error.value) and missing.key in str(error.value)
    assert f"notebooks/{missing.chapter}.ipynb" in str(error.value)


def test_the_page_executes_after_every_chapter():
    """Sphinx reads, and myst-nb executes, documents in sorted order: the page must sort after the chapters."""
    toc = yaml.safe_load((REPO_ROOT / "_toc.yml").read_text())
    files = [ch["file"] for part in toc["parts"] for ch in part["chapters"]]
    assert "reference/ledger" in files and "book/claims" not in files
    assert all(f < "reference/ledger" for f in files if f.startswith("notebooks/"))
    page = nbformat.read(PAGE, as_version=4)
    assert all(not c.get("outputs") for c in page.cells if c.cell_type == "code"), "stored without outputs"
    assert any("parameters" in c.metadata.get("tags", []) for c in page.cells)


def test_chapter_summary_shows_whole_texts(tmp_cache):
    made = _record_all(REGENERATED[:2])
    styled = ledger.chapter_summary(made)
    assert list(styled.data["status"]) == [r.status_text() for r in made]
    assert "test text for " + made[0].key in styled.to_html()
    with pytest.raises(TypeError, match="ClaimRecord"):
        ledger.chapter_summary([])


def test_a_planned_claim_cannot_be_recorded(tmp_cache, monkeypatch):
    from hoi_tutorial.ledger import records

    planned = ledger.Claim("samp.planned_example", "SAMP", "Table 9", "s", "1.0", None, planned="not built")
    monkeypatch.setattr(records, "claim", lambda key: planned)
    with pytest.raises(ValueError, match="planned"):
        ledger.record("samp.planned_example", seed=0, scale="toy", ours="text")


def test_the_library_digest_leaves_out_how_artifacts_are_stored(monkeypatch):
    # A record goes stale when code a claim computes with changes; mending the cache or the pack computes nothing.
    from hoi_tutorial.ledger import records

    seen = {}
    monkeypatch.setattr(records, "_library_digest", lambda stamp: seen.setdefault("files", [p for p, _ in stamp]))
    records.library_digest()
    hashed = {records._module_name(p) for p in seen["files"]}
    assert "hoi_tutorial.nifty.guidance" in hashed and "hoi_tutorial.intervals" in hashed
    assert not hashed & {"hoi_tutorial.infra.cache", "hoi_tutorial.infra.cache_store", "hoi_tutorial.infra.pack",
                         "hoi_tutorial.ledger.records", "hoi_tutorial"}
