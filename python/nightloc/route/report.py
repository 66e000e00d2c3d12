"""What ``nightloc route`` reports about a run: the ``summary.json`` contents of one method and
of a comparison, and the words for the filter's motion model."""

from __future__ import annotations

import json
import math

import numpy as np

from ..preparation.params import PreparationParams
from .evaluation import GroundTruth, RouteEvaluation
from .params import DISTANCE_MOTIONS
from .pipeline import RouteResult

__all__ = ["COMPARED", "comparison_summary", "method_summary", "motion_line", "route_metrics", "summary_json"]

#: The figures a comparison of methods reports side by side.
COMPARED = ("best_f1", "recall_at_100_precision", "correct_any_score")


def route_metrics(result: RouteResult, evaluation: RouteEvaluation) -> dict:
    """summary.json's precision-recall figures. Thresholds are on the score scale (a match is
    accepted when its score is at most the threshold; the filter's score is ``1 - confidence``);
    ``confidence_at_100_precision`` is the same threshold on the filter's confidence scale
    (:meth:`RouteResult.confidence_at`, as the confidence figure draws it; None for SeqSLAM)."""
    positives = int(evaluation.positives.sum())
    return {
        "recall_at_100_precision": evaluation.recall_at_100,
        "score_scale": "1 - confidence" if result.method == "filter" else "uniqueness ratio",
        "threshold_at_100_precision": _finite_or_none(evaluation.threshold_at_100),
        "confidence_at_100_precision": result.confidence_at(evaluation.threshold_at_100),
        "best_f1": evaluation.best_f1,
        "best_f1_precision": evaluation.best_f1_precision,
        "best_f1_recall": evaluation.best_f1_recall,
        "best_f1_threshold": _finite_or_none(evaluation.best_f1_threshold),
        "correct_any_score": int(evaluation.correct.sum()) / positives if positives else None,
    }


def method_summary(
    result: RouteResult,
    evaluation: RouteEvaluation | None,
    reference: object,
    query: object,
    preparation: PreparationParams | None,
    truth: GroundTruth | None,
    truth_kind: str,
    no_truth: str,
    figures: list,
) -> dict:
    """One method's ``summary.json``: the traverses (their roots), sizes, the method's own
    parameters, the motion model and why, the speed check, the preparation, timings (s), the ground truth and,
    with it, :func:`route_metrics`."""
    p = result.params
    summary = {
        "method": p.method,
        "reference": str(reference),
        "query": str(query),
        "n_refs": result.n_refs,
        "n_queries": result.n_queries,
        "n_matched": int(result.defined.sum()),
        "method_params": p.method_params(),  # the settings this method uses (no other method's)
        "motion_model": result.motion,
        "motion_model_because": result.motion_note or None,
        "speed_check": None if result.speed_check is None else result.speed_check.as_dict(),
        "preparation": None
        if preparation is None
        else {field: getattr(preparation, field) for field in preparation.__dataclass_fields__},
        "timings_s": {key: round(value, 4) for key, value in result.timings.items()},
        "ground_truth": truth_kind,
        "no_ground_truth_because": no_truth or None,
        "tolerance": None if truth is None else truth.tolerance,
        "figures": figures,
    }
    if evaluation is not None:
        summary.update(route_metrics(result, evaluation))
    return summary


def comparison_summary(summaries: dict, figures: list) -> dict:
    """The ``summary.json`` of several methods run on one difference matrix: each method's folder,
    :data:`COMPARED` figures, search time (s) and parameters."""
    return {
        "methods": list(summaries),
        "figures": figures,
        "results": {
            method: {
                "folder": method,
                **{key: summary.get(key) for key in COMPARED},
                "search_s": summary["timings_s"].get("search"),
                "method_params": summary["method_params"],
            }
            for method, summary in summaries.items()
        },
    }


def summary_json(summary: dict) -> str:
    """A summary as ``summary.json``'s text (numpy numbers as numbers, other objects as text)."""
    return json.dumps(summary, indent=1, default=_json_default) + "\n"


def motion_line(result: RouteResult) -> str:
    """The filter's motion model for the printed line, with the reason when odometry was not used."""
    words = result.motion_words()
    if result.motion in DISTANCE_MOTIONS:
        return f"{words} ({result.motion_note})"
    if result.motion_note and "neither" not in result.motion_note:
        return f"{words}: {result.motion_note}"
    return words


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _json_default(value: object) -> object:
    if isinstance(value, (np.integer, np.floating)):
        return value.item()
    return str(value)
