"""The sections of issue 31: H1 in a correlated world (the class-to-room ties of the paper's domain), and
the search with the domain's scene model (the SP-POMDP analysing every view: Sec. III-B, Fig. 3).

Both can be run alone and spliced into an existing report (``python -m benchmarks.search_paper
--only-scenes``): they sit between :data:`BEGIN` and :data:`END`.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time

from beliefloc.knowledge import KnowledgeBase
from beliefloc.knowledge.domain import Domain
from beliefloc.object_search.experiment import Arm, TrialRecord, TrialSettings, room_hit, trial_world
from beliefloc.object_search.scene import distractors, scene_model, solve_scene
from beliefloc.object_search.scene_views import room_classes
from beliefloc.object_search.settings import Scenes
from beliefloc.object_search.space import SearchSpace
from beliefloc.object_search.trials import Stream, robot_domain, sample_known, trial_rng
from benchmarks.stats import mean, paired_p, sd

from .report import Report, p_value
from .running import outcomes
from .settings import KNOWLEDGE, NO_LIMIT, NONE, ROOT, Part

BEGIN = "<!-- scene models (issue 31): python -m benchmarks.search_paper --only-scenes -->"
END = "<!-- end of the scene models' sections -->"

H1_CORRELATION = 0.97
"""The correlated world of H1's new setting: every object in its class's home room with probability 0.97."""
H1_RHOS = (0.9, 0.95, 0.97, 1.0)
"""The ties compared at 40 % and 100 % knowledge."""

SCENE_ASP = Arm("pomdp", NONE, time_limit=NO_LIMIT, scenes=Scenes.PLANNED)
SCENE_ONLY = Arm("pomdp-only", NONE, time_limit=NO_LIMIT, scenes=Scenes.PLANNED)
SCENE_ALL = Arm("pomdp", NONE, time_limit=NO_LIMIT, scenes=Scenes.ALL)
SCENE_ASP_LIMITED = Arm("pomdp", NONE, scenes=Scenes.PLANNED)
SCENE_ALL_LIMITED = Arm("pomdp", NONE, scenes=Scenes.ALL)
FIXED_ASP = Arm("pomdp", NONE, time_limit=NO_LIMIT, scenes=Scenes.FIXED)
SCENE_ARMS = (SCENE_ASP, SCENE_ONLY, SCENE_ALL, SCENE_ASP_LIMITED, SCENE_ALL_LIMITED, FIXED_ASP)


def scene_part(trials: int) -> Part:
    """40 % knowledge with defaults, target present: the SP-POMDP's searches against POMDP only, against
    applying every operator, and the fixed detector."""
    return Part("scene models", TrialSettings(knowledge=0.4, defaults=True), SCENE_ARMS, trials, scenes=True)


def h1_hits(
    domain: Domain,
    space: SearchSpace,
    typical: dict[str, str],
    *,
    knowledge: float,
    correlation: float | None,
    trials: int,
    seed: int,
) -> tuple[float, float]:
    """Top-1 and top-2 room hits of the knowledge base's prior (no defaults) over ``trials`` worlds -- the
    worlds and knowledge :func:`~beliefloc.object_search.experiment.run_trial` draws, without the searches."""
    settings = TrialSettings(knowledge=knowledge, defaults=False, correlation=correlation)
    top1 = top2 = 0.0
    for index in range(trials):
        world = trial_world(domain, space, typical, index=index, seed=seed, settings=settings)
        known = sample_known(domain, world, knowledge, trial_rng(seed, index, Stream.KNOWLEDGE))
        prior = KnowledgeBase(robot_domain(domain, world, known), use_defaults=False).prior(world.target_class)
        ranked = space.over_rooms(prior.prior)
        true = space.rooms.index(world.target_room or "")
        top1 += room_hit(ranked, true, 1)
        top2 += room_hit(ranked, true, 2)
    return top1 / trials, top2 / trials


def h1_correlated_section(
    report: Report, domain: Domain, space: SearchSpace, typical: dict[str, str], trials: int, seed: int
) -> None:
    began = time.perf_counter()
    curves = {
        level: (
            h1_hits(domain, space, typical, knowledge=level, correlation=None, trials=trials, seed=seed),
            h1_hits(domain, space, typical, knowledge=level, correlation=H1_CORRELATION, trials=trials, seed=seed),
        )
        for level in KNOWLEDGE
    }
    rhos = {
        (rho, level): h1_hits(domain, space, typical, knowledge=level, correlation=rho, trials=trials, seed=seed)
        for rho in H1_RHOS
        for level in (0.4, 1.0)
    }
    report.add(
        "## H1 in a correlated world: the paper's class-to-room ties",
        "",
        '> **Paper** (Sec. IV-A): "rooms hold objects of related classes"; without defaults, 40 % knowledge: top-1 '
        "≈ 0.7, top-2 ≈ 0.9; 100 %: the correct room. **Targets** (issue 31): top-2 at 40 % ≥ 0.85 and top-1 at "
        "100 % ≥ 0.95, without defaults.",
        "",
        "The *old setting* is the world of the sections above (an object with a default in its default room with "
        "probability 0.8; the domain file's own placements kept, some of them exceptions such as `computer4` in the "
        f"bedroom). The *new setting* is a correlated world, `search simulate --correlation {H1_CORRELATION:g}` "
        "(`TrialSettings(correlation=...)`, `world.place_objects`): every object -- those the file places too -- is "
        f"in its class's home room with probability ρ = {H1_CORRELATION:g}, else in one of the other rooms; a "
        "class's home room is its nearest default's room (`world.class_rooms`: pillow and blanket the bedroom, "
        "computer and printer and textbook the study, cookbook, cup and plate the kitchen, remote the living room), "
        "and for magazine, which no default covers, the room the file places most magazines in -- one each in "
        "bedroom, study and living room, so the first listed, the bedroom. Knowledge base without defaults; the "
        f"prior's rank of the target's true room; {trials} trials per point, the same targets as above.",
        "",
        "| knowledge | old: top-1 | old: top-2 | new: top-1 | new: top-2 |",
        "| ---: | ---: | ---: | ---: | ---: |",
    )
    for level, ((old1, old2), (new1, new2)) in curves.items():
        report.add(f"| {100 * level:.0f} % | {old1:.3f} | {old2:.3f} | **{new1:.3f}** | **{new2:.3f}** |")
    new40, new100 = curves[0.4][1], curves[1.0][1]
    report.add(
        "",
        f"Targets: top-2 at 40 % = **{new40[1]:.3f}** (≥ 0.85: {'met' if new40[1] >= 0.85 else 'NOT met'}), top-1 at "
        f"100 % = **{new100[0]:.3f}** (≥ 0.95: {'met' if new100[0] >= 0.95 else 'NOT met'}). The old setting gives "
        f"{curves[0.4][0][1]:.3f} and {curves[1.0][0][0]:.3f}.",
        "",
        "How strong the ties must be (ρ: the probability an object is in its class's home room):",
        "",
        "| ρ | 40 %: top-1 | 40 %: top-2 | 100 %: top-1 | 100 %: top-2 |",
        "| ---: | ---: | ---: | ---: | ---: |",
    )
    for rho in H1_RHOS:
        (a1, a2), (b1, b2) = rhos[rho, 0.4], rhos[rho, 1.0]
        report.add(f"| {rho:g} | {a1:.3f} | {a2:.3f} | {b1:.3f} | {b2:.3f} |")
    meeting = [rho for rho in H1_RHOS if rhos[rho, 0.4][1] >= 0.85 and rhos[rho, 1.0][0] >= 0.95]
    smallest = f"ρ = {min(meeting):g}" if meeting else "none"
    at40 = rhos[min(meeting), 0.4][0] if meeting else float("nan")
    report.add(
        "",
        f"The smallest ρ of the table meeting both targets: {smallest}. The paper's top-1 ≈ 0.7 at 40 % is not "
        f"matched there ({at40:.3f}): ties strong enough for the 100 % level leave little to guess at 40 % (five "
        "instances per class, related classes in the same room). "
        f"Computed from the priors alone in {time.perf_counter() - began:.0f} s.",
        "",
    )


def scene_section(
    report: Report, domain: Domain, space: SearchSpace, typical: dict[str, str], records: list[TrialRecord]
) -> None:
    model = scene_model(domain)
    assert model is not None
    n = len(records)

    def per(arm: Arm, what: str) -> list[float]:
        values = []
        for o in outcomes(records, arm):
            if what == "time":
                values.append(o.time)
            elif what == "accuracy":
                values.append(o.accuracy)
            elif what == "ops":
                values.append((o.operators_applied or 0) / max(1, o.steps))
            elif what == "processing":
                values.append(o.processing_time or 0.0)
            elif what == "found":
                values.append(float(o.verdict.value == "found"))
        return values

    asp_t, only_t, all_t = (per(a, "time") for a in (SCENE_ASP, SCENE_ONLY, SCENE_ALL))
    asp_ops, all_ops = per(SCENE_ASP, "ops"), per(SCENE_ALL, "ops")
    asp_acc, all_acc = per(SCENE_ASP_LIMITED, "accuracy"), per(SCENE_ALL_LIMITED, "accuracy")
    asp_acc_u, all_acc_u = per(SCENE_ASP, "accuracy"), per(SCENE_ALL, "accuracy")
    # the solve time of every view kind of the domain: each target class, each room
    solve_ms = []
    for cls in domain.classes:
        if cls not in model.appearance:
            continue
        for classes in room_classes(domain, space.rooms, typical, cls):
            for apply_all in (False, True):
                best = float("inf")
                for _ in range(3):  # the best of three, as timeit does: the machine is shared
                    started = time.perf_counter()
                    solve_scene(model, model.look(cls), distractors(model, classes), apply_all=apply_all)
                    best = min(best, time.perf_counter() - started)
                solve_ms.append(1000 * best)
    fixed_s, planned_s = simulate_seconds("fixed"), simulate_seconds("planned")
    report.add(
        "## With the scene model: the SP-POMDP analyses every view (Sec. III-B, Fig. 3)",
        "",
        "> **Paper:** the SP-POMDP plans which ROIs to process with which visual operators; its decision is the "
        "VS-POMDP's observation. **Targets** (issue 31): ASP+POMDP faster than POMDP alone (paired, p < 0.01); fewer "
        "operators per scene than applying all of them, accuracy no lower; a view solved in ≤ 5 ms.",
        "",
        f"`domains/home.yaml`'s scene model: {model.rois} ROIs per view, operators "
        + ", ".join(f"{op.name} ({op.cost:g} time units)" for op in model.operators)
        + f"; LL error cost {model.error_cost:g}; HL thresholds {model.present_threshold:g} / "
        f"{model.absent_threshold:g}, scene time limit {model.time_limit:g}. {n} paired trials, 40 % knowledge with "
        "defaults, target present, the old world (as in Fig. 5). Time: until a cell passes τ+ = 0.8 (1000 as a "
        'guard); accuracy: at τ+ or 100 time units ("limited"), and at τ+ ("unlimited"). *all*: every operator '
        f"on every ROI ({len(model.operators) * model.rois} per scene), the likelier answer at the end.",
        "",
        "| arm | time | of it, processing | operators per scene | found (unlimited) | accuracy (limited) "
        "| accuracy (unlimited) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    )
    rows = (
        ("ASP+POMDP, SP-POMDP (planned)", SCENE_ASP, SCENE_ASP_LIMITED),
        ("POMDP only, SP-POMDP (planned)", SCENE_ONLY, None),
        ("ASP+POMDP, every operator on every ROI", SCENE_ALL, SCENE_ALL_LIMITED),
        ("ASP+POMDP, fixed detector (no scene model)", FIXED_ASP, None),
    )
    for label, arm, limited in rows:
        t, proc, ops, found = per(arm, "time"), per(arm, "processing"), per(arm, "ops"), per(arm, "found")
        lim = f"{mean(per(limited, 'accuracy')):.3f}" if limited is not None else "-"
        proc_text = f"{mean(proc):.1f}" if arm is not FIXED_ASP else "-"
        ops_text = f"{mean(ops):.2f}" if arm is not FIXED_ASP else "-"
        report.add(
            f"| {label} | {mean(t):.1f} ± {sd(t):.1f} | {proc_text} | {ops_text} | {100 * mean(found):.1f} % | {lim} | "
            f"{mean(per(arm, 'accuracy')):.3f} |"
        )
    p_time = paired_p(asp_t, only_t)
    p_ops = paired_p(asp_ops, all_ops)
    p_acc = paired_p(asp_acc, all_acc)
    p_acc_u = paired_p(asp_acc_u, all_acc_u)
    p_all_time = paired_p(asp_t, all_t)
    faster = p_time is not None and p_time < 0.01 and mean(asp_t) < mean(only_t)
    report.add(
        "",
        f"- ASP+POMDP against POMDP only, both with the SP-POMDP: {mean(asp_t):.1f} against {mean(only_t):.1f} time "
        f"units, p = {p_value(p_time)} (target p < 0.01: {'met' if faster else 'NOT met'}).",
        f"- Planned against every operator: {mean(asp_ops):.2f} against {mean(all_ops):.2f} operator applications per "
        f"scene (p = {p_value(p_ops)}); search time {mean(asp_t):.1f} against {mean(all_t):.1f} (p = "
        f"{p_value(p_all_time)}); accuracy {mean(asp_acc):.3f} against {mean(all_acc):.3f} with the time limit (p = "
        f"{p_value(p_acc)}), {mean(asp_acc_u):.3f} against {mean(all_acc_u):.3f} without (p = {p_value(p_acc_u)}).",
        f"- Solving one view kind (a target class in a room, planned or all; {len(solve_ms)} kinds, uncached, best of "
        "three): median "
        f"{statistics.median(solve_ms):.2f} ms, max {max(solve_ms):.2f} ms (target ≤ 5 ms); a search looks each kind "
        "up in a cache afterwards.",
        f"- `beliefloc {' '.join(SIMULATE)}` (one process, best of three): {planned_s:.1f} s with the scene model "
        f"against {fixed_s:.1f} s with the fixed detector (`--scenes fixed`): {planned_s / fixed_s:.2f}x "
        "(target ≤ 2x).",
        "",
    )


SIMULATE = ("search", "simulate", "domains/home.yaml", "-n", "200", "--no-timings")
"""The command whose time is compared with and without the scene model (target: at most twice)."""


def simulate_seconds(scenes: str, repeats: int = 3) -> float:
    """Wall-clock seconds of ``beliefloc search simulate domains/home.yaml -n 200 --scenes SCENES`` in a
    child process (the best of ``repeats``: the machine is shared)."""
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "beliefloc", *SIMULATE, "--scenes", scenes],
            cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
            check=True,
            capture_output=True,
        )
        best = min(best, time.perf_counter() - started)
    return best


def splice(text: str, section: str) -> str:
    """``text`` with the part between :data:`BEGIN` and :data:`END` replaced by ``section`` (inserted
    before ``## Figures``, or at the end, when there is none)."""
    block = f"{BEGIN}\n\n{section.rstrip()}\n\n{END}\n"
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        return head + block + rest.split(END, 1)[1].lstrip("\n")
    if "\n## Figures" in text:
        head, tail = text.split("\n## Figures", 1)
        return head.rstrip("\n") + "\n\n" + block + "\n## Figures" + tail
    return text.rstrip("\n") + "\n\n" + block
