"""The results ledger: every claim of the three papers, the paper's numbers, and what a chapter computed.

``claims`` lists the claims (paper, table or section, the claim in words, the paper's numbers taken from
the paper packages' ``paper_numbers`` modules, the chapter that regenerates it). A chapter calls
:func:`record` once per claim with what it computed and which directions held; the record is written to
the artifact cache. The ledger page (``reference/ledger.ipynb``) builds its tables with :func:`ledger_rows`
from those records alone, and fails, naming the claim and its chapter, when a record is missing or was
made by another version of the chapter or the library: the ledger cannot show numbers the chapters did
not compute.

Typical use at the end of a chapter::

    from hoi_tutorial import ledger

    ledger.record("nifty.t4.samples", seed=SEED, scale=SCALE,
                  checks={"skeleton distance falls from N = 1 to 10 (sit)": gap.verdict("above")},
                  ours=f"mean skeleton distance {d1:.2f} m with N = 1, {d10:.2f} m with N = 10")

where ``gap = intervals.paired_difference(skel_1, skel_10)`` is the paired interval over the same test
scenes: a direction whose interval straddles zero is recorded as *inconclusive*.
"""
from .claims import CLAIMS, PAPERS, Claim, claim
from .records import (STATUSES, ClaimRecord, LedgerError, chapter_digest, chapter_summary, chapter_title,
                      ledger_rows, library_digest, load_record, markdown_table, record, record_path, status_of,
                      summary, verdict_of)

__all__ = ["CLAIMS", "PAPERS", "Claim", "claim", "STATUSES", "ClaimRecord", "LedgerError", "chapter_digest",
           "chapter_summary", "chapter_title", "ledger_rows", "library_digest", "load_record",
           "markdown_table", "record", "record_path", "status_of", "summary", "verdict_of"]
