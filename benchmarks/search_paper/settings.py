"""The settings of the object-search reproduction: the domain, the knowledge levels, time limits, Beta
priors and trust factors of the figures, the arms compared, and the parts (sets of paired trials) that
run them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from beliefloc.object_search.experiment import Arm, TrialSettings
from beliefloc.object_search.posterior import Detector, TrustFactor
from beliefloc.object_search.settings import Metareasoning, Revision

ROOT = Path(__file__).resolve().parents[2]
DOMAIN = ROOT / "domains" / "home.yaml"
RESULTS = ROOT / "benchmarks" / "results" / "search-paper.md"

KNOWLEDGE = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
NO_LIMIT = 1000.0
"""The paper's "unless otherwise stated, there is no time limit": a search that never passes τ+ stops here."""
H3_LIMITS = (10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 80.0, 100.0, 150.0)
"""The baseline's time limits in Fig. 7."""
BETAS = ((3.0, 1.0), (6.0, 2.0), (30.0, 10.0))
"""Fig. 8: one mean (0.75), three variances; the paper names (6, 2) and (30, 10)."""
NOISY_WORLD = Detector(true_positive=0.8, false_positive=0.2)
"""Fig. 6's world: the robot's model says p_TP = 0.9, p_FP = 0.1 (home.yaml); the world errs twice as often."""
TRUST_GRID = ((0.5, 0.0), (0.25, 0.0), (0.75, 0.0), (0.25, 1.0), (0.5, 1.0), (0.75, 1.0))
"""Trust factors (w, r) of the sensitivity table; the first is the main arm (TrustFactor's defaults)."""
STRICTER_TAU = (0.9, 0.95, 0.99)
"""Fig. 6's control: Eq. 7 (static KB) stopping at a stricter τ+, to compare the arms at equal time."""
CDF_CELLS = (0.0, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0)

METAREASONING = (Metareasoning.EXPECTATION, Metareasoning.UPPER_BOUND, Metareasoning.SAMPLING)
NONE = Metareasoning.NONE


@dataclass(frozen=True)
class Part:
    """A set of paired trials: every arm on trials ``0 .. trials - 1`` with the same settings."""

    label: str
    settings: TrialSettings
    arms: tuple[Arm, ...]
    trials: int
    scenes: bool = False
    """Analyse views with the domain's scene model (issue 31); False: the fixed detector of ``search:``,
    which every part but the scene models' uses (the sections above predate the scene model)."""


# the arms

ASP_LIMITED = Arm("pomdp", NONE)
ASP_UNLIMITED = Arm("pomdp", NONE, time_limit=NO_LIMIT)
ONLY_LIMITED = Arm("pomdp-only", NONE)
ONLY_UNLIMITED = Arm("pomdp-only", NONE, time_limit=NO_LIMIT)
GREEDY_UNLIMITED = Arm("greedy", NONE, time_limit=NO_LIMIT)
STATIC = Arm("pomdp", NONE)
DYNAMIC = Arm("pomdp", NONE, dynamic_kb=True)
TRUST = Arm("pomdp", NONE, Revision.TRUST)
FIG6_ARMS = {"static KB": STATIC, "dynamic KB": DYNAMIC, "trust factor": TRUST}
FIG6_CONTROLS = {
    **{f"static KB, τ+ = {tau:g}": Arm("pomdp", NONE, tau_found=tau) for tau in STRICTER_TAU},
    f"dynamic KB, τ+ = {STRICTER_TAU[-1]:g}": Arm("pomdp", NONE, dynamic_kb=True, tau_found=STRICTER_TAU[-1]),
}
H1_TYPICAL = (0.4, 1.0)
"""Knowledge levels of H1 re-run with every object in its default room (p_typical = 1), without defaults."""


def trust_arm(weight: float, r: float) -> Arm:
    if (weight, r) == TRUST_GRID[0]:
        return TRUST
    return Arm("pomdp", NONE, Revision.TRUST, trust=TrustFactor(weight, r))


def baseline_arm(limit: float) -> Arm:
    return Arm("pomdp", NONE, time_limit=limit)


def fig7_arm(metareasoning: Metareasoning) -> Arm:
    return Arm("pomdp", metareasoning, time_limit=NO_LIMIT, tau_absent=0.7)


def fig8_arm(metareasoning: Metareasoning, beta: tuple[float, float]) -> Arm:
    return Arm("pomdp", metareasoning, time_limit=NO_LIMIT, tau_absent=0.85, alpha=beta[0], beta=beta[1])


def knowledge_parts(trials: int) -> list[Part]:
    parts = []
    for defaults in (False, True):
        for level in KNOWLEDGE:
            arms = [ASP_LIMITED, ASP_UNLIMITED]
            if level == 0.0 and not defaults:
                arms += [ONLY_LIMITED, ONLY_UNLIMITED]
            if level == 0.4 and defaults:
                arms += [GREEDY_UNLIMITED]
            label = f"knowledge {100 * level:.0f} % {'with' if defaults else 'without'} defaults"
            parts.append(Part(label, TrialSettings(knowledge=level, defaults=defaults), tuple(arms), trials))
    return parts


def typical_parts(trials: int) -> list[Part]:
    """H1 with every object in its default room: only the prior is read, one cheap arm runs."""
    return [
        Part(
            f"knowledge {100 * level:.0f} % without defaults, objects in their default rooms",
            TrialSettings(knowledge=level, defaults=False, p_typical=1.0),
            (ASP_LIMITED,),
            trials,
        )
        for level in H1_TYPICAL
    ]


def kb_parts(trials: int) -> list[Part]:
    noisy = TrialSettings(knowledge=0.2, defaults=False, world_detector=NOISY_WORLD)
    arms = (STATIC, DYNAMIC, *(trust_arm(w, r) for w, r in TRUST_GRID), *FIG6_CONTROLS.values())
    matched = TrialSettings(knowledge=0.2, defaults=False)
    return [
        Part("Fig. 6, noisier world", noisy, arms, trials),
        Part("Fig. 6, the model's noise", matched, (STATIC, DYNAMIC, TRUST), trials),
    ]


def meta_part(trials: int) -> Part:
    arms = [baseline_arm(limit) for limit in H3_LIMITS]
    arms += [fig7_arm(s) for s in METAREASONING]
    arms += [fig8_arm(s, b) for s in METAREASONING for b in BETAS]
    return Part("Figs. 7-8, target absent in half", TrialSettings(absent_fraction=0.5), tuple(arms), trials)
