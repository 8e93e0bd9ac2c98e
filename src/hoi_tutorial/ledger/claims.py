"""Every claim of NIFTY, SAMP and CHOICE that the book regenerates (or plans to), with the paper's numbers.

A :class:`Claim` says what the paper claims and where; the paper's numbers are read from the paper packages'
``paper_numbers`` modules (transcribed there once, exactly), or, for a figure or an algorithm, say that the
paper prints none. What *we* computed is never written here: the chapter named by ``chapter`` records it
(:func:`hoi_tutorial.ledger.record`).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Mapping, Optional, Sequence

from ..choice import paper_numbers as choice_numbers
from ..nifty import paper_numbers as nifty_numbers
from ..samp import paper_numbers as samp_numbers

__all__ = ["PAPERS", "Claim", "CLAIMS", "claim"]

PAPERS = ("NIFTY", "SAMP", "CHOICE")
_KEY_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789._")


@dataclasses.dataclass(frozen=True)
class Claim:
    """One claim of a paper.

    key: a stable identifier, ``"<paper>.<where>.<what>"`` in lower case (the name chapters record under).
    paper: one of :data:`PAPERS`. source: where the paper makes it ("Table 1", "§5.2", "Fig. 4").
    statement: the claim in words. paper_numbers: the paper's numbers for it, as one line of text.
    chapter: the notebook stem of the chapter that regenerates it, or ``None`` when no chapter does yet;
    then ``planned`` says what is missing.
    """
    key: str
    paper: str
    source: str
    statement: str
    paper_numbers: str
    chapter: Optional[str]
    planned: str = ""

    def __post_init__(self):
        if not self.key or set(self.key) - _KEY_CHARS or not self.key.startswith(self.paper.lower() + "."):
            raise ValueError(f"claim key {self.key!r}: expected lower-case letters, digits, '.' and '_', "
                             f"starting with {self.paper.lower()!r}.")
        if self.paper not in PAPERS:
            raise ValueError(f"claim {self.key}: paper {self.paper!r}, expected one of {PAPERS}")
        if (self.chapter is None) != bool(self.planned):
            raise ValueError(f"claim {self.key}: a claim without a chapter needs `planned` (what is missing), "
                             "and only such a claim has one")


# ----------------------------------------------------------------------------------------- quoting the tables


def _text(value, decimals: Optional[int] = None) -> str:
    """A transcribed value as printed: ``decimals`` for a column printed with fixed decimals (NIFTY's
    tables: 0.00, 65.40), or, with ``None``, the digits the transcription holds (SAMP's 11.7, 3.8)."""
    if isinstance(value, str):
        return value
    if value is None:
        return "—"
    if isinstance(value, int):
        return str(value)
    if math.isinf(value):
        return "∞"
    return repr(value) if decimals is None else f"{value:.{decimals}f}"


def _decimals(values) -> int:
    """The most decimals any of ``values`` is printed with (the transcriptions keep the paper's digits)."""
    most = 0
    for value in values:
        if isinstance(value, float) and math.isfinite(value):
            text = repr(value)
            if "e" not in text and "." in text:
                most = max(most, len(text.split(".")[1].rstrip("0")) or 1)
    return max(most, 0)


def _column_decimals(table: Mapping, column: str) -> int:
    """Decimals of one column over a table ({row: {column: value}}, or {group: {row: {column: value}}})."""
    values = []
    for row in table.values():
        if column in row:
            values.append(row[column])
        else:
            values.extend(r.get(column) for r in row.values() if isinstance(r, Mapping))
    decimals = _decimals([v for v in values if v is not None])
    # A column printed with two decimals keeps them where the value ends in zeros (0.00, 65.40).
    return max(decimals, 1) if any(isinstance(v, float) for v in values) else 0


def _grouped(tables: Mapping[str, Mapping[str, Mapping[str, object]]], rows: Sequence[str],
             columns: Sequence[str], groups: Optional[Sequence[str]] = None, unit: str = "") -> str:
    """``"col (row1 / row2): group a / b, group a / b; ..."`` for tables split by group (sit / lift)."""
    groups = list(groups or tables)
    parts = []
    for column in columns:
        decimals = max(_column_decimals(tables[g], column) for g in groups)
        per_group = []
        for g in groups:
            cells = [_text(tables[g].get(r, {}).get(column), decimals) for r in rows]
            per_group.append(f"{g} {' / '.join(cells)}")
        parts.append(f"{column}{unit} ({' / '.join(rows)}): {', '.join(per_group)}")
    return "; ".join(parts)


# SAMP prints some values with fewer digits than their column (Table 2's 11.7, Table 5's 3.8): those
# tables are quoted value by value (``_text(v)``); the others with their column's decimals.


def _cells(table: Mapping[str, Mapping[str, object]], row: str, columns: Sequence[str]) -> str:
    """``"col v, col v"``: one row of a table of rows (methods) by columns."""
    return ", ".join(f"{c} {_text(table[row].get(c), _column_decimals(table, c))}" for c in columns if c in table[row])


def _rowwise(table: Mapping[str, Mapping[str, object]], rows: Sequence[str], columns: Sequence[str]) -> str:
    """``"row: col v, col v; row: ..."`` for a table of rows (methods) by columns."""
    return "; ".join(f"{r}: {_cells(table, r, columns)}" for r in rows)


def _columnwise(table: Mapping[str, Mapping[str, object]], rows: Sequence[str], columns: Sequence[str]) -> str:
    """``"col (row1 / row2 / row3): v / v / v; ..."`` for a table of rows (methods) by columns."""
    parts = []
    for c in columns:
        decimals = _column_decimals(table, c)
        parts.append(f"{c} ({' / '.join(rows)}): {' / '.join(_text(table[r].get(c), decimals) for r in rows)}")
    return "; ".join(parts)


_N = nifty_numbers
_S = samp_numbers
_C = choice_numbers
_T1_METHODS = list(_N.TABLE1_METHODS)
_D2O, _SKEL, _IOU = "% D2O ≤ 2cm ↑", "Skel. Dist. ↓", "Contact IoU ↑"
_PEN, _SKATE = "% Pen. ≤ 2cm ↑", "Foot Skating ↓"
_SKEL25 = "% Skel. Dist. ≤ 25cm ↑"
_FIGURE = "a figure; the paper prints no numbers for it"
_T3_LEARNED = ["Diffusion", "INTP-2Ch-D_t", "INTP-2Ch-D_o'", "INTP-3Channels"]
_T3_ALL = ["cuRobo"] + _T3_LEARNED
_T4_VARIANTS = ["w/o goal phase", "w/ matched goal", "w/ predicted goal", "w/ KF goal"]
_T2_SHORT = "; ".join(f"{action} / {task} {seconds} s ({share} %)" for action, task, seconds, share in _C.TABLE2)

CLAIMS = (
    # ------------------------------------------------------------------------------------------------- NIFTY
    Claim("nifty.t1.reach", "NIFTY", "Table 1",
          "NIFTY beats Cond. VAE and Cond. MDM on distance to object (D2O) and skeleton distance, for sitting "
          "and lifting", _grouped(_N.TABLE1, _T1_METHODS, [_D2O, _SKEL]), "06_evaluating_nifty"),
    Claim("nifty.t1.contact_penetration", "NIFTY", "Table 1",
          "NIFTY has the best contact IoU and penetration score (% Pen. ≤ 2cm)",
          _grouped(_N.TABLE1, _T1_METHODS, [_IOU, _PEN]), "06_evaluating_nifty"),
    Claim("nifty.t1.skating", "NIFTY", "Table 1", "Cond. MDM skates least",
          _grouped(_N.TABLE1, _T1_METHODS, [_SKATE]), "06_evaluating_nifty"),
    Claim("nifty.t1.cond_mdm", "NIFTY", "Table 1, Cond. MDM row",
          "the object-conditioned diffusion model without guidance approaches the object but rarely reaches it "
          "(low % D2O ≤ 2cm, large skeleton distance)",
          _grouped(_N.TABLE1, ["Cond. MDM", "NIFTY"], [_D2O, _SKEL]), "04_object_conditioned_motion_model"),
    Claim("nifty.s32.guidance", "NIFTY", "§3.2",
          "guidance with the interaction field moves the final pose towards the interaction (Table 1's NIFTY "
          "row against Cond. MDM, the same model unguided; the book sets it against the best of N unguided "
          "samples chosen by the same G, so that selection cannot carry the gain)",
          _grouped(_N.TABLE1, ["Cond. MDM", "NIFTY"], [_D2O, _SKEL]), "05_object_interaction_fields"),
    Claim("nifty.fig3.field_vectors", "NIFTY", "Fig. 3",
          "the interaction field's vectors point from a pose back towards a valid interaction pose",
          _FIGURE, "05_object_interaction_fields"),
    Claim("nifty.fig4.rollout_trees", "NIFTY", "Fig. 4",
          "top-down, the paths of a rollout tree converge on one anchor pose from many directions",
          _FIGURE, "03_synthetic_interaction_data"),
    Claim("nifty.t2.offset_field", "NIFTY", "Table 2",
          "an offset (vector) interaction field beats a field predicting a single distance",
          _grouped(_N.TABLE2, ["Distance OIF", "NIFTY"], [_D2O, _SKEL]), "07_nifty_ablations_field"),
    Claim("nifty.t3.nearest_anchor", "NIFTY", "Supp. Table 3",
          "the learned (parametric) interaction field beats a nearest-anchor (non-parametric) one on % Skel. "
          "Dist. ≤ 25cm and contact IoU",
          _grouped(_N.TABLE3, ["Non-Parametric", "Parametric"], [_SKEL25, _IOU]), "07_nifty_ablations_field"),
    Claim("nifty.t7.frame", "NIFTY", "Supp. Table 7",
          "a field in the object's canonical frame beats one in the human's local frame",
          _grouped(_N.TABLE7, ["Local Human", "Canonical"], [_D2O, _SKEL]), "08_nifty_ablations_frame"),
    Claim("nifty.t4.samples", "NIFTY", "Supp. Table 4",
          "more guided samples (N, the best kept) give better results",
          _grouped(_N.TABLE4, ["1", "2", "5", "10"], [_D2O, _SKEL]), "09_nifty_ablations_sampling"),
    Claim("nifty.t5.anchors", "NIFTY", "Supp. Table 5",
          "fewer anchor poses give worse skeleton distance and contact IoU, while skating, D2O and penetration "
          "stay stable", _grouped(_N.TABLE5, ["10%", "25%", "50%", "100%"], [_SKEL, _IOU, _D2O]),
          "09_nifty_ablations_sampling"),
    Claim("nifty.t6.window", "NIFTY", "Supp. Table 6",
          "a multi-frame interaction field is feasible (frames the field sees: 1 is NIFTY)",
          _grouped(_N.TABLE6, ["1", "5", "10", "15"], [_D2O, _SKEL]), "10_nifty_ablations_window"),
    Claim("nifty.t8.per_object", "NIFTY", "Supp. Table 8", "NIFTY's results are stable across object categories",
          _grouped(_N.TABLE8, list(_N.TABLE8["sit"]), [_D2O], groups=["sit"]) + "; "
          + _grouped(_N.TABLE8, list(_N.TABLE8["lift"]), [_D2O], groups=["lift"]), "06_evaluating_nifty"),
    Claim("nifty.fig10_11.penetration_vs_approach", "NIFTY", "Supp. Figs. 10, 11",
          "penetration as a function of approach length N_A: NIFTY ahead of both baselines at every N_A",
          _FIGURE, "06_evaluating_nifty"),
    Claim("nifty.fig5.user_study", "NIFTY", "Fig. 5, §4.4",
          "people prefer NIFTY's motions to both baselines', and find them nearly indistinguishable from the "
          "synthetic data (the book asks a classifier)",
          "preferred in ≥ {sit} % of pairs (sit), ≥ {lift} % (lift) against the baselines; over both actions "
          .format(**_N.FIG5_PREFERRED_FLOOR)
          + ", ".join(f"{v} % against {k}" for k, v in _N.FIG5_PREFERRED_MEAN.items()), "06_evaluating_nifty"),
    Claim("nifty.a1.data_realism", "NIFTY", "Supp. A.1, Fig. 8",
          "the synthetic training data looks nearly as realistic as real mocap (the book asks a classifier)",
          "Likert realism of sitting motions (1-5): " + ", ".join(f"{k} {v}" for k, v in _N.LIKERT_REALISM.items()),
          "06_evaluating_nifty"),
    # -------------------------------------------------------------------------------------------------- SAMP
    Claim("samp.goalnet.error_and_diversity", "SAMP", "§5.2, GoalNet",
          "GoalNet reconstructs unseen goals closely and its sampled goals are diverse (APD)",
          "reconstruction: " + _cells(_S.GOALNET, "reconstruction", ["position (cm)", "direction (deg)"]) + "; "
          + _rowwise(_S.GOALNET, ["GoalNet", "GT"], ["APD-Pos (cm)", "APD-Rot (deg)"]),
          "11_samp_goals_and_paths"),
    Claim("samp.fig7.sideways", "SAMP", "Fig. 7",
          "GoalNet lets a character sit sideways on a chair, not on an armchair", _FIGURE, "11_samp_goals_and_paths"),
    Claim("samp.s33.astar", "SAMP", "§3.3, Fig. 9", "A* finds an obstacle-free path to the goal",
          "an algorithm; the paper prints no numbers for it", "11_samp_goals_and_paths"),
    Claim("samp.t1.diversity", "SAMP", "Table 1",
          "the diversity (APD) of SAMP's motion is close to the ground truth's and greater than 0",
          _columnwise(_S.TABLE1, ["GT", "SAMP"], ["Walk", "Run", "Sit", "Liedown"]), "12_samp_motionnet"),
    Claim("samp.s52.motionnet_reaches_goals", "SAMP", "§5.2",
          "MotionNet reaches sit and lie-down goals on unseen objects",
          "SAMP in Table 3: " + _cells(_S.TABLE3, "SAMP", ["Sit PE (cm)", "Liedown PE (cm)"])
          + "; in Table 2: sit " + _text(_S.TABLE2["Sit"]["SAMP"]) + " s, lie down "
          + _text(_S.TABLE2["Liedown"]["SAMP"]) + " s", "12_samp_motionnet"),
    Claim("samp.suppd.scheduled_sampling", "SAMP", "§3.2, Supp. D",
          "without scheduled sampling MotionNet's predictions are poor at run time: it is needed to reach goals",
          "stated in words; the paper prints no numbers for it", "12_samp_motionnet"),
    Claim("samp.t2.execution_time", "SAMP", "Table 2",
          "MLP and MoE fail to lie down (∞) and are slower than SAMP",
          "; ".join(f"{action} (MLP / MoE / SAMP / GT): "
                    + " / ".join(_text(_S.TABLE2[action][m]) for m in ("MLP", "MoE", "SAMP", "GT")) + " s"
                    for action in _S.TABLE2), "13_samp_baselines"),
    Claim("samp.t3.precision", "SAMP", "Table 3", "SAMP is more precise at the goal than MLP and MoE",
          _columnwise(_S.TABLE3, ["MLP", "MoE", "SAMP"], list(_S.TABLE3["SAMP"])), "13_samp_baselines"),
    Claim("samp.t4.frechet", "SAMP", "Table 4",
          "SAMP's Fréchet distance to the captured motion is lower than MLP's and MoE's",
          _columnwise(_S.TABLE4, ["MLP", "MoE", "SAMP"], list(_S.TABLE4["SAMP"])), "13_samp_baselines"),
    Claim("samp.s42.augmentation", "SAMP", "§4.2, Supp. F",
          "augmenting the captured interactions onto other objects lets MotionNet adapt to unseen objects",
          "stated in words; the paper prints no numbers for it", "13_samp_baselines"),
    Claim("samp.suppg.interaction_encoder", "SAMP", "Supp. G", "the interaction encoder improves precision",
          _rowwise(_S.NO_INTERACTION_ENCODER, list(_S.NO_INTERACTION_ENCODER), ["PE (cm)", "RE (deg)"]),
          "13_samp_baselines"),
    Claim("samp.s52.path_planning", "SAMP", "§5.2, path planning",
          "path planning lowers the share of frames with a penetration",
          "; ".join(f"{k} {v} %" for k, v in _S.PATH_PLANNING_PENETRATION.items()), "14_samp_pipeline"),
    Claim("samp.fig2.pipeline", "SAMP", "Fig. 2, §3.3",
          "the whole pipeline (GoalNet, A*, MotionNet) reaches sit goals in cluttered rooms",
          "shown in figures and video; the paper prints no success rate", "14_samp_pipeline"),
    Claim("samp.t5.nsm", "SAMP", "Table 5", "SAMP against a deterministic, NSM-like model on sitting and carrying",
          "; ".join(f"{action} (SAMP / NSM): " + ", ".join(
              f"{c} {_text(_S.TABLE5[action]['SAMP'][c], _FD)} / {_text(_S.TABLE5[action]['NSM'][c], _FD)}"
              for c in ("Precision PE (cm)", "FD", "Diversity", "Penetration (%)")
              for _FD in [2 if c == "FD" else None]) for action in _S.TABLE5),
          "14_samp_pipeline"),
    # ------------------------------------------------------------------------------------------------ CHOICE
    Claim("choice.fig11.latent_clusters", "CHOICE", "Fig. 11",
          "the planner's latent codes cluster by furniture, and an unseen layout's code lies beside similar "
          "scenes'", _FIGURE, "16_choice_planner"),
    Claim("choice.t3.success", "CHOICE", "Table 3",
          "the 3-channel planner succeeds on unseen layouts",
          _grouped(_C.TABLE3, ["INTP-3Channels"], ["succ. rate"], unit=" (%)"), "17_choice_table3"),
    Claim("choice.s823.merged_channel", "CHOICE", "§8.2.3",
          "merging D_t and D_o into one channel (INTP-2Ch-D_o') costs success",
          _grouped(_C.TABLE3, ["INTP-2Ch-D_o'", "INTP-3Channels"], ["succ. rate"], unit=" (%)"), "17_choice_table3"),
    Claim("choice.t3.c1_safety", "CHOICE", "Table 3 (C1)",
          "the 3-channel planner keeps the largest safety distance among the learned planners",
          _grouped(_C.TABLE3, _T3_LEARNED, ["safety dist."], unit=" (cm)"), "17_choice_table3"),
    Claim("choice.t3.c2_reshaping", "CHOICE", "Table 3 (C2)",
          "with reshaped furniture the 3-channel planner is smoother and safer than the 2-channel ones, and the "
          "diffusion policy succeeds least",
          _grouped(_C.TABLE3, _T3_LEARNED, ["unsmooth.", "safety dist.", "succ. rate"], groups=["w/ reshaping"]),
          "17_choice_table3"),
    Claim("choice.t3.curobo", "CHOICE", "Table 3",
          "the minimum-jerk optimiser (cuRobo) is smooth and reliable without reshaping",
          _grouped(_C.TABLE3, ["cuRobo", "INTP-3Channels"], ["unsmooth.", "succ. rate"]), "17_choice_table3"),
    Claim("choice.t3.diffusion_policy", "CHOICE", "Table 3",
          "the Diffusion Policy is the least successful planner; its paths are over-straight or collide in "
          "narrow scenes", _grouped(_C.TABLE3, _T3_ALL, ["succ. rate"], unit=" (%)"), "17_choice_table3"),
    Claim("choice.alg1.kalman_filter", "CHOICE", "§5.2, Algorithm 1",
          "the goal-phase Kalman filter (Eqs. 15–22) tracks the goal phase from the network's and the matched "
          "motion's measurements", "an algorithm; the paper prints no numbers for it", "18_choice_phase_kalman"),
    Claim("choice.t2.labels", "CHOICE", "Table 2", "the distribution of action labels per key joint",
          _T2_SHORT, "19_choice_pick_and_place"),
    Claim("choice.t4.c3_kalman_best", "CHOICE", "Table 4 (C3)",
          "the Kalman-filtered goal phase gives the best unsmoothness, sliding, Fréchet distance and wrist RMS "
          "curvature of the four goal-phase sources",
          _columnwise(_C.TABLE4, _T4_VARIANTS, list(_C.TABLE4_COLUMNS)), "19_choice_pick_and_place"),
    Claim("choice.t4.c4_no_phase_worst", "CHOICE", "Table 4 (C4)", "without a goal phase the controller is worst",
          _columnwise(_C.TABLE4, _T4_VARIANTS, list(_C.TABLE4_COLUMNS)), "19_choice_pick_and_place"),
    Claim("choice.t4.dataset_sliding", "CHOICE", "Table 4",
          "the recorded motion slides far less than any controller variant",
          _columnwise(_C.TABLE4, ["Dataset", "w/ KF + cuRobo"] + _T4_VARIANTS, ["Slid."]), "19_choice_pick_and_place"),
    Claim("choice.t4.planner_vs_curobo", "CHOICE", "Table 4",
          "the learned planner's trajectories make better motion than cuRobo's",
          _columnwise(_C.TABLE4, ["w/ KF + cuRobo", "w/ KF goal"], list(_C.TABLE4_COLUMNS)),
          "19_choice_pick_and_place"),
    Claim("choice.s6.pick_and_place", "CHOICE", "§6, Fig. 1",
          "the character walks to a cabinet, opens it with one hand, takes the bottle with the other and puts "
          "it on the table, without collision", "a demonstration; the paper prints no numbers for it",
          "19_choice_pick_and_place"),
)

_BY_KEY = {c.key: c for c in CLAIMS}
if len(_BY_KEY) != len(CLAIMS):
    raise RuntimeError("two claims share a key")


def claim(key: str) -> Claim:
    """The claim registered under ``key``; a clear error naming the known keys otherwise."""
    if not isinstance(key, str) or key not in _BY_KEY:
        raise KeyError(f"no claim {key!r} in the ledger; expected one of: {', '.join(sorted(_BY_KEY))}")
    return _BY_KEY[key]
