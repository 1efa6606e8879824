"""Where the robot probably is, at the command line: ``prior --robot``, ``--belief prior:DOMAIN``
for plan, track and show, and ``simulate --start prior`` (the library is tested in test_robot_prior.py).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from beliefloc import compile_model, load_map
from beliefloc.belief import update
from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT
from beliefloc.knowledge import OUTSIDE, load_domain, robot_start_belief
from beliefloc.planning.best_first import plan

from .conftest import DATA, MAPS, ROOT

APARTMENT_MAP = MAPS / "apartment.yaml"
APARTMENT = ROOT / "domains" / "apartment.yaml"
TWO_ROOMS = DATA / "rooms" / "two-rooms.yaml"
TWO_ROOMS_DOMAIN = DATA / "rooms" / "two-rooms-domain.yaml"
ROOMS = ("bedroom", "study", "corridor", "living_room", "kitchen")


# --- the command line: prior --robot ----------------------------------------------------------------


def test_prior_robot_prints_the_room_prior(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(APARTMENT), "--robot"])
    assert out.exit_code == 0, out.output
    assert "where is the robot? (apartment, step 2)" in out.stdout
    rows = {line.split("│")[1].strip(): line for line in out.stdout.splitlines() if line.startswith("│")}
    assert "0.900" in rows["kitchen"] and "the robot is here: w = 0.9" in rows["kitchen"]
    assert "0.025" in rows["study"] and "elsewhere: (1 - w) / 4" in rows["study"]
    assert "12" in rows["kitchen"], "the kitchen's cells on the map"


def test_prior_robot_json(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(APARTMENT), "--robot", "--json", "--weight", "0.6"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["rooms"] == list(ROOMS) and data["robot_in"] == ["kitchen"] and data["weight"] == 0.6
    assert data["prior"] == pytest.approx(
        {"bedroom": 0.1, "study": 0.1, "corridor": 0.1, "living_room": 0.1, "kitchen": 0.6}
    )
    assert data["cells"]["study"] == 18 and data["uniform"] is False and data["answer_sets"] == 1


def test_prior_robot_with_cells_in_no_room(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(TWO_ROOMS_DOMAIN), "--robot", "--json"])
    data = json.loads(out.stdout)
    assert data["rooms"] == ["kitchen", "study", OUTSIDE] and data["cells"][OUTSIDE] == 1
    assert data["prior"] == pytest.approx({"kitchen": 0.9, "study": 0.05, OUTSIDE: 0.05})


def test_prior_robot_says_when_nothing_is_known(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(ROOT / "domains" / "home.yaml"), "--robot", "--json"])
    assert out.exit_code == 0
    assert json.loads(out.stdout)["uniform"] is True
    assert "does not say where the robot is" in " ".join(out.stderr.split())


@pytest.mark.parametrize(
    ("extra", "message"),
    [(["--target", "cup"], "drop --target"), (["--explain"], "drop --target and --explain")],
)
def test_prior_robot_refuses_object_options(extra: list[str], message: str, runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(APARTMENT), "--robot", *extra])
    assert out.exit_code == EXIT_BAD_INPUT and message in out.stderr


def test_weight_needs_robot(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(APARTMENT), "--weight", "0.5"])
    assert out.exit_code == EXIT_BAD_INPUT and "use it with --robot" in out.stderr


# --- the command line: --belief prior:DOMAIN ---------------------------------------------------------


def _prior_belief() -> np.ndarray:
    model = compile_model(load_map(APARTMENT_MAP))
    return robot_start_belief(model, load_domain(APARTMENT)).belief


def test_plan_from_the_knowledge_base_prior(runner: CliRunner) -> None:
    out = runner.invoke(app, ["plan", str(APARTMENT_MAP), "--belief", f"prior:{APARTMENT}", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    expected = plan(compile_model(load_map(APARTMENT_MAP)), _prior_belief())
    assert data["found"] and data["cost"] == expected.cost
    assert [s["action"] for s in data["steps"]] == [s.action for s in expected.steps]


def test_track_from_the_knowledge_base_prior(runner: CliRunner) -> None:
    out = runner.invoke(app, ["track", str(APARTMENT_MAP), "--belief", f"prior:{APARTMENT}", "look=fridge", "--json"])
    assert out.exit_code == 0, out.output
    model = compile_model(load_map(APARTMENT_MAP))
    expected, _ = update(model, _prior_belief(), "look", "fridge")
    got = np.array(list(json.loads(out.stdout)["belief"].values()))
    np.testing.assert_allclose(got, expected, atol=1e-15)


def test_show_json_of_the_prior_holds_w_on_the_kitchen(runner: CliRunner) -> None:
    out = runner.invoke(app, ["show", str(APARTMENT_MAP), "--belief", f"prior:{APARTMENT}", "--json"])
    assert json.loads(out.stdout)["rooms"]["kitchen"] == pytest.approx(0.9, abs=1e-12)


def test_a_built_model_finds_its_map_for_the_prior(runner: CliRunner, tmp_path: Path) -> None:
    model_file = tmp_path / "apartment.npz"
    assert runner.invoke(app, ["build", str(APARTMENT_MAP), "-o", str(model_file)]).exit_code == 0
    out = runner.invoke(app, ["plan", str(model_file), "--belief", f"prior:{APARTMENT}", "--json"])
    assert out.exit_code == 0, out.output


@pytest.mark.parametrize(
    ("source", "domain", "message"),
    [
        (MAPS / "kitchen.yaml", APARTMENT, r"kitchen\.yaml has no rooms"),
        (APARTMENT_MAP, ROOT / "domains" / "home.yaml", "rooms of the map the domain lacks: corridor"),
        (APARTMENT_MAP, TWO_ROOMS_DOMAIN, "rooms of the map the domain lacks: bedroom, corridor, living_room$"),
        (DATA / "pomdp" / "tiger.pomdp", APARTMENT, "was not compiled from a map"),
    ],
    ids=["no-rooms", "missing-room", "other-rooms", "pomdp"],
)
def test_prior_belief_needs_matching_rooms(source: Path, domain: Path, message: str, runner: CliRunner) -> None:
    out = runner.invoke(app, ["plan", str(source), "--belief", f"prior:{domain}"])
    assert out.exit_code == EXIT_BAD_INPUT, out.output
    text = " ".join(out.stderr.split())
    assert text.startswith(f"error: --belief prior:{domain}: ") or "was not compiled" in text, text
    assert "Traceback" not in out.output
    assert re.search(message, text), text


# --- simulate --start prior ---------------------------------------------------------------------------


def test_simulate_draws_true_starts_from_the_start_belief(runner: CliRunner, tmp_path: Path) -> None:
    belief = tmp_path / "belief.yaml"
    belief.write_text('"7,8": 0.5\n"9,11": 0.5\n', encoding="utf-8")
    args = ["simulate", str(APARTMENT_MAP), "-n", "6", "--belief", str(belief), "--start", "prior", "--json"]
    out = runner.invoke(app, [*args, "--no-timings"])
    assert out.exit_code in (0, 1), out.output
    starts = [episode["start"] for episode in json.loads(out.stdout)["episodes"]]
    assert {start.rsplit(",", 1)[0] for start in starts} <= {"7,8", "9,11"}
    assert len(set(starts)) > 1
    again = runner.invoke(app, [*args, "--no-timings"])
    assert again.stdout == out.stdout


def test_simulate_from_the_prior_starts_mostly_in_the_kitchen(runner: CliRunner) -> None:
    args = ["simulate", str(APARTMENT_MAP), "-n", "20", "--belief", f"prior:{APARTMENT}", "--start", "prior"]
    out = runner.invoke(app, [*args, "--json", "--no-timings", "--max-steps", "1"])
    starts = [episode["start"] for episode in json.loads(out.stdout)["episodes"]]
    kitchen = sum(7 <= int(s.split(",")[0]) <= 9 and 8 <= int(s.split(",")[1]) <= 11 for s in starts)
    assert kitchen >= 15, starts
