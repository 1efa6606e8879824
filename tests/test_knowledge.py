"""Knowledge bases in ASP -> room priors (Zhang, Sridharan & Wyatt 2015, Sec. III-A and III-C1)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from beliefloc.cli.app import app
from beliefloc.errors import EXIT_BAD_INPUT, InvalidValueError, KnowledgeBaseError
from beliefloc.knowledge import (
    KnowledgeBase,
    Observation,
    domain_from_data,
    domain_prior,
    load_domain,
    room_prior,
    room_prior_from_answer,
)

from .conftest import ROOT

KB_DIR = ROOT / "kb"

DOMAINS = ROOT / "domains"
PRINTER = DOMAINS / "printer-example.yaml"


def small(**extra: Any) -> dict[str, Any]:
    """Three rooms, books and magazines under book_magazine, computers and printers under computer_access."""
    data: dict[str, Any] = {
        "name": "small",
        "rooms": ["bedroom", "study", "kitchen"],
        "classes": {
            "object": None,
            "book_magazine": "object",
            "computer_access": "object",
            "book": "book_magazine",
            "magazine": "book_magazine",
            "textbook": "book",
            "cookbook": "book",
            "computer": "computer_access",
            "printer": "computer_access",
        },
        "objects": {},
    }
    data.update(extra)
    return data


def prior_of(target: str, **extra: Any) -> dict[str, float]:
    return domain_prior(domain_from_data(small(**extra)), target).prior


# -- the printer example (Sec. III-C1) ---------------------------------------------------------


def test_printer_example_alpha_and_prior() -> None:
    result = domain_prior(load_domain(PRINTER), "printer")
    assert [round(result.alpha[r], 3) for r in result.rooms] == [0.250, 1.141, 0.375]
    assert [round(result.prior[r], 3) for r in result.rooms] == [0.142, 0.646, 0.212]
    assert result.rooms == ("bedroom", "study", "kitchen")
    pillow = next(t for t in result.terms if t.primary == "pillow")
    assert (pillow.count, pillow.height, pillow.weights, pillow.lca) == (1, 3, (1, 2, 4), "object")


def test_printer_example_cli_json(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(PRINTER), "--target", "printer", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["rooms"] == ["bedroom", "study", "kitchen"]
    assert [round(data["alpha"][r], 3) for r in data["rooms"]] == [0.250, 1.141, 0.375]
    assert [round(data["prior"][r], 3) for r in data["rooms"]] == [0.142, 0.646, 0.212]


def test_printer_example_cli_explain(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(PRINTER), "--explain"])
    assert out.exit_code == 0, out.output
    assert "0.646" in out.stdout and "1 x 2 x 4" in out.stdout and "computer_access" in out.stdout


# -- Postulates 1-3 (Eq. 2-4) on a hand-made domain ----------------------------------------------


def test_postulate_1_support_grows_with_the_log_of_the_count() -> None:
    objects = {f"c{i}": {"class": "computer", "room": "study"} for i in range(4)}
    objects["c9"] = {"class": "computer", "room": "kitchen"}
    result = domain_prior(domain_from_data(small(objects=objects)), "printer")
    # computer -> computer_access (2 children): W = (1, 2)
    assert result.alpha["study"] == pytest.approx((math.log(4) + 1) / 2)
    assert result.alpha["kitchen"] == pytest.approx(1 / 2)


def test_postulate_2_support_is_diluted_by_siblings_up_to_the_lca() -> None:
    near = {"c1": {"class": "computer", "room": "study"}}
    far = {"m1": {"class": "magazine", "room": "study"}}
    deep = {"t1": {"class": "textbook", "room": "study"}}
    alpha = {
        name: domain_prior(domain_from_data(small(objects=o)), "printer").alpha["study"]
        for name, o in (("near", near), ("far", far), ("deep", deep))
    }
    assert alpha["near"] == pytest.approx(1 / 2)  # W = (1, 2): computer_access has 2 children
    assert alpha["far"] == pytest.approx(1 / (1 * 2 * 2))  # magazine -> book_magazine (2) -> object (2)
    assert alpha["deep"] == pytest.approx(1 / (1 * 2 * 2 * 2))  # textbook -> book (2) -> book_magazine -> object
    # the target's own class: H = 1, no dilution
    own = {"p1": {"class": "printer", "room": "study"}}
    assert domain_prior(domain_from_data(small(objects=own)), "printer").alpha["study"] == pytest.approx(1.0)


def test_postulate_3_primary_classes_add_up() -> None:
    objects = {"c1": {"class": "computer", "room": "study"}, "m1": {"class": "magazine", "room": "study"}}
    result = domain_prior(domain_from_data(small(objects=objects)), "printer")
    assert result.alpha["study"] == pytest.approx(1 / 2 + 1 / 4)
    assert len([t for t in result.terms if t.room == "study"]) == 2


def test_room_prior_is_pure_and_sums_to_one() -> None:
    counts = {"a": {"x": 2}, "b": {}}
    parents = {"x": "root", "y": "root"}
    result = room_prior(["a", "b"], parents, counts, "y")
    assert counts == {"a": {"x": 2}, "b": {}}
    assert sum(result.prior.values()) == pytest.approx(1.0)
    assert result.floored == ("b",) and result.prior["b"] == pytest.approx(0.01)
    assert result.message is not None and "floor" in result.message


def test_room_prior_owns_its_json_shape() -> None:
    result = domain_prior(load_domain(PRINTER), "printer")
    data = result.as_json()
    assert list(data) == ["rooms", "alpha", "prior", "target", "uniform", "floored", "answer_sets", "terms"]
    assert data["rooms"] == list(result.rooms) and data["prior"] == result.prior and data["target"] == "printer"
    assert data["floored"] == [] and data["uniform"] is False and data["answer_sets"] == 1
    pillow = next(t for t in data["terms"] if t["class"] == "pillow")
    assert pillow == {
        "room": "bedroom",
        "class": "pillow",
        "count": 1,
        "lca": "object",
        "height": 3,
        "weights": [1, 2, 4],
        "psi": pytest.approx(1 / 8),
    }
    assert json.loads(json.dumps(data)) == data


def test_room_prior_from_answer_is_the_kb_prior() -> None:
    kb = KnowledgeBase(load_domain(PRINTER))
    assert room_prior_from_answer(kb.answer(), "printer") == kb.prior("printer")
    with pytest.raises(KnowledgeBaseError, match="unknown target class 'unicorn'"):
        room_prior_from_answer(kb.answer(), "unicorn")


def test_no_support_anywhere_gives_a_uniform_prior_and_says_so(runner: CliRunner, tmp_path: Path) -> None:
    result = domain_prior(domain_from_data(small()), "printer")
    assert result.uniform and list(result.prior.values()) == pytest.approx([1 / 3] * 3)
    path = tmp_path / "empty.yaml"
    path.write_text("name: e\nrooms: [a, b]\nclasses: {object: null, thing: object}\n")
    out = runner.invoke(app, ["prior", str(path), "--target", "thing"])
    assert out.exit_code == 0
    assert "uniform" in out.stderr


def test_floor_out_of_range_is_a_usage_error(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(PRINTER), "--floor", "0.5"])
    assert out.exit_code == EXIT_BAD_INPUT
    assert "floor" in out.stderr


# -- defaults and their exceptions (Sec. III-A) --------------------------------------------------

BOOKS_IN_STUDY = {"class": "book", "room": "study"}
PRML_SPICES = {"prml": {"class": "textbook"}, "spices": {"class": "cookbook"}, "mystery": {"class": "book"}}


def located(**default: Any) -> dict[str, str]:
    domain = domain_from_data(small(objects=PRML_SPICES, defaults={"d": {**BOOKS_IN_STUDY, **default}}))
    return KnowledgeBase(domain).answer().located()


def test_default_places_every_book_in_the_study() -> None:
    assert located() == {"prml": "study", "spices": "study", "mystery": "study"}


def test_weak_exception_silences_the_default() -> None:
    assert located(weak_exceptions=["cookbook"]) == {"prml": "study", "mystery": "study"}


def test_weak_exception_second_form_needs_to_know_it_is_not_one() -> None:
    # a book of unknown kind might be a cookbook: the default no longer applies to it
    assert located(possible_exceptions=["cookbook"]) == {"prml": "study"}


def test_strong_exception_falsifies_the_default() -> None:
    domain = domain_from_data(
        small(objects=PRML_SPICES, defaults={"d": {**BOOKS_IN_STUDY, "strong_exceptions": ["cookbook"]}})
    )
    answer = KnowledgeBase(domain).answer()
    assert answer.located() == {"prml": "study", "mystery": "study"}
    assert "-holds(in(spices,study),2)" in {str(lit) for lit in answer.at()}


def test_default_yields_to_an_observation() -> None:
    objects = {"prml": {"class": "textbook", "room": "bedroom"}}
    domain = domain_from_data(small(objects=objects, defaults={"d": BOOKS_IN_STUDY}))
    assert KnowledgeBase(domain).answer().located() == {"prml": "bedroom"}


def test_defaults_change_the_prior_and_can_be_switched_off() -> None:
    objects = {"prml": {"class": "textbook"}}
    domain = domain_from_data(small(objects=objects, defaults={"d": BOOKS_IN_STUDY}))
    with_defaults = domain_prior(domain, "magazine")
    without = domain_prior(domain, "magazine", use_defaults=False)
    assert with_defaults.prior["study"] > 0.9 and without.uniform


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


PAPER_DOMAIN = """name: paper
rooms: [bedroom, study, kitchen]
classes: {object: null, book: object}
kb: [paper.lp]
"""


def test_kb_answer_prml_and_spices(runner: CliRunner, tmp_path: Path) -> None:
    """Sec. III-A: with the weak exception, in(prml, study) is inferred; nothing about spices."""
    domain = write(tmp_path, "paper.yaml", PAPER_DOMAIN)
    write(tmp_path, "paper.lp", "is(prml, textbook).\nis(spices, cookbook).\n")
    out = runner.invoke(app, ["kb", "answer", str(domain), "--kb", str(KB_DIR / "books.lp"), "--step", "1", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["holds"]["in"] == ["holds(in(prml,study),1)"]
    assert not any("spices" in lit for lit in data["holds"].get("-in", []))
    assert "ab(d_book_in_study(spices))" in data["ab"]


def test_kb_answer_prml_moved_to_the_bedroom(runner: CliRunner, tmp_path: Path) -> None:
    """Sec. III-A's non-monotonic revision: holds(in(prml, bedroom), 2) withdraws in(prml, study) at 2."""
    domain = write(tmp_path, "paper.yaml", PAPER_DOMAIN)
    write(tmp_path, "paper.lp", "is(prml, book).\nholds(in(prml, study), 1).\n")
    before = json.loads(runner.invoke(app, ["kb", "answer", str(domain), "--json"]).stdout)["holds"]
    assert "holds(in(prml,study),2)" in before["in"]
    assert "holds(exists(book,study),2)" in before["exists"]
    out = runner.invoke(app, ["kb", "answer", str(domain), "--json", "--seen", "prml=bedroom"])
    after = json.loads(out.stdout)["holds"]
    assert after["in"] == ["holds(in(prml,bedroom),2)"]
    assert "-holds(in(prml,study),2)" in after["-in"]
    assert "holds(exists(book,bedroom),2)" in after["exists"]
    assert "holds(exists(book,study),2)" not in after["exists"]
    step1 = json.loads(runner.invoke(app, ["kb", "answer", str(domain), "--json", "--step", "1"]).stdout)
    assert step1["holds"]["in"] == ["holds(in(prml,study),1)"]


def test_kb_answer_table(runner: CliRunner) -> None:
    out = runner.invoke(app, ["kb", "answer", str(PRINTER)])
    assert out.exit_code == 0, out.output
    assert "holds(in(book4,kitchen),2)" in out.stdout and "exists" in out.stdout


# -- revision (multi-shot) -----------------------------------------------------------------------


def test_revision_changes_the_prior_and_the_same_fact_twice_changes_nothing() -> None:
    kb = KnowledgeBase(load_domain(PRINTER))
    before = kb.prior("printer")
    assert kb.observe(Observation("book1", "bedroom"))  # a known object, seen elsewhere
    after = kb.prior("printer")
    assert after.alpha["bedroom"] > before.alpha["bedroom"] and after.alpha["study"] < before.alpha["study"]
    assert not kb.observe(Observation("book1", "bedroom"))
    assert kb.prior("printer") == after


def test_revision_with_a_new_object_grounds_again() -> None:
    kb = KnowledgeBase(load_domain(PRINTER))
    kb.observe(Observation("book1", "bedroom"))
    assert kb.observe(Observation("printer2", "kitchen", "printer"))
    result = kb.prior("printer")
    assert any(t.primary == "printer" and t.room == "kitchen" for t in result.terms)
    assert kb.answer().located()["book1"] == "bedroom"  # earlier observations are kept
    with pytest.raises(KnowledgeBaseError, match="unknown object 'ghost': give its class"):
        kb.observe(Observation("ghost", "kitchen"))


def test_inconsistent_observation_names_the_fact_and_is_taken_back() -> None:
    kb = KnowledgeBase(load_domain(PRINTER))
    kb.observe(Observation("book1", "bedroom"))
    with pytest.raises(KnowledgeBaseError, match=r"inconsistent.*holds\(in\(book1,kitchen\),2\)"):
        kb.observe(Observation("book1", "kitchen"))
    assert kb.answer().located()["book1"] == "bedroom"


def test_inconsistent_program_exits_2(runner: CliRunner, tmp_path: Path) -> None:
    bad = write(tmp_path, "bad.lp", "-holds(in(book1, study), 1).\n")
    out = runner.invoke(app, ["kb", "check", str(PRINTER), "--kb", str(bad)])
    assert out.exit_code == EXIT_BAD_INPUT
    assert "the knowledge base is inconsistent" in out.stderr


def test_several_answer_sets_use_the_cautious_consequences(tmp_path: Path) -> None:
    choice = write(
        tmp_path,
        "choice.lp",
        "holds(in(book1, study), 1) :- not holds(in(book1, kitchen), 1).\n"
        "holds(in(book1, kitchen), 1) :- not holds(in(book1, study), 1).\n",
    )
    domain = domain_from_data(small(objects={"book1": {"class": "book"}, "c1": {"class": "computer", "room": "study"}}))
    kb = KnowledgeBase(domain, [choice])
    answer = kb.answer()
    assert answer.models == 2 and "book1" not in answer.located()
    result = kb.prior("printer")
    assert result.models == 2 and result.message is not None and "cautious" in result.message


# -- errors -------------------------------------------------------------------------------------


def test_lp_syntax_error_names_file_line_column(runner: CliRunner, tmp_path: Path) -> None:
    bad = write(tmp_path, "broken.lp", "% fine\nis(x, book).\nholds(in(x, study) 1).\n")
    out = runner.invoke(app, ["kb", "check", str(PRINTER), "--kb", str(bad)])
    assert out.exit_code == EXIT_BAD_INPUT
    assert f"{bad}:3:20: syntax error" in out.stderr
    assert "Traceback" not in out.output


def test_clingo_warnings_are_shown_once(runner: CliRunner, tmp_path: Path) -> None:
    odd = write(tmp_path, "odd.lp", "holds(in(X, study), 1) :- is(X, book), fragile(X).\n")
    kb = KnowledgeBase(load_domain(PRINTER), [odd])
    kb.answer()
    assert len([w for w in kb.warnings if "fragile" in w]) == 1
    out = runner.invoke(app, ["prior", str(PRINTER), "--kb", str(odd)])
    assert out.exit_code == 0
    assert out.stderr.count("fragile") == 1


def test_unknown_target_is_a_usage_error(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(PRINTER), "--target", "unicorn"])
    assert out.exit_code == EXIT_BAD_INPUT
    assert "unknown class" in out.stderr and "printer" in out.stderr


def test_missing_kb_file(runner: CliRunner) -> None:
    out = runner.invoke(app, ["kb", "check", str(PRINTER), "--kb", "nowhere.lp"])
    assert out.exit_code == EXIT_BAD_INPUT and "no such knowledge-base file" in out.stderr


# -- shipped files and help -----------------------------------------------------------------------


@pytest.mark.parametrize("path", sorted(DOMAINS.glob("*.yaml")), ids=lambda p: p.name)
def test_every_shipped_domain_loads_and_solves(path: Path, runner: CliRunner) -> None:
    domain = load_domain(path)
    kb = KnowledgeBase(domain)
    assert kb.answer().models == 1 and kb.warnings == []
    if domain.target is not None:
        assert sum(kb.prior(domain.target).prior.values()) == pytest.approx(1.0)
    out = runner.invoke(app, ["kb", "check", str(path), "--json"])
    assert out.exit_code == 0 and json.loads(out.stdout)["consistent"]


@pytest.mark.parametrize("path", sorted(KB_DIR.glob("*.lp")), ids=lambda p: p.name)
def test_every_shipped_kb_file_grounds_with_every_domain(path: Path) -> None:
    for domain_path in sorted(DOMAINS.glob("*.yaml")):
        kb = KnowledgeBase(load_domain(domain_path), [path])
        assert kb.answer().models == 1
        assert kb.warnings == []


def test_home_domain_has_50_objects_in_10_categories() -> None:
    domain = load_domain(DOMAINS / "home.yaml")
    assert len(domain.objects) == 50 and len({o.class_ for o in domain.objects.values()}) == 10
    assert list(domain.rooms) == ["bedroom", "study", "kitchen", "living_room"]
    assert domain.defaults


@pytest.mark.parametrize("command", [["prior"], ["kb", "check"], ["kb", "answer"]])
def test_help_has_an_example(command: list[str], runner: CliRunner) -> None:
    out = runner.invoke(app, [*command, "--help"])
    assert out.exit_code == 0 and "Example" in out.stdout and "\n    beliefloc " in out.stdout


def test_seen_malformed(runner: CliRunner) -> None:
    out = runner.invoke(app, ["prior", str(PRINTER), "--seen", "book1"])
    assert out.exit_code == EXIT_BAD_INPUT and "OBJECT=ROOM" in out.stderr


# -- values, checked by the library in its own words ---------------------------------------------


def test_the_target_is_the_one_named_else_the_domain_s() -> None:
    domain = load_domain(PRINTER)
    assert domain.resolve_target("computer") == "computer"
    assert domain.resolve_target(None) == domain.target == "printer"
    with pytest.raises(InvalidValueError, match=r"^unknown class; expected one of: bedding, book, "):
        domain.resolve_target("unicorn")


def test_a_domain_without_a_target_needs_one_named() -> None:
    domain = domain_from_data(small())
    with pytest.raises(InvalidValueError, match=r"^no target class given and the domain names none; expected one of"):
        domain.resolve_target(None)
    assert domain.resolve_target(None, allow_any=True) is None
    assert domain.resolve_target("any", allow_any=True) is None
    assert domain.resolve_target("book", allow_any=True) == "book"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["prior", str(PRINTER), "--target", "unicorn"], "error: --target 'unicorn': unknown class; expected one of:"),
        (["prior", str(PRINTER), "--seen", "book1"], "error: --seen 'book1': write OBJECT=ROOM or OBJECT:CLASS=ROOM"),
        (["kb", "answer", str(PRINTER), "--seen", "=study"], "error: --seen '=study': write OBJECT=ROOM"),
        (["kb", "answer", str(PRINTER), "--step", "3"], "error: --step 3: the domain has steps 1..2"),
        (["prior", str(DOMAINS / "apartment.yaml"), "--robot", "--weight", "0"], "error: --weight: the weight w must"),
        (["prior", str(DOMAINS / "apartment.yaml"), "--robot", "--weight", "1.5"], "error: --weight: the weight w"),
    ],
    ids=["target", "prior-seen", "kb-seen", "step", "weight-0", "weight-1.5"],
)
def test_the_option_a_bad_value_came_from_is_named(args: list[str], message: str, runner: CliRunner) -> None:
    out = runner.invoke(app, args)
    assert out.exit_code == EXIT_BAD_INPUT and out.stdout == ""
    assert " ".join(out.stderr.split()).startswith(message), out.stderr


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("book5=kitchen", Observation("book5", "kitchen")),
        (" book5 = kitchen ", Observation("book5", "kitchen")),
        ("printer2:printer=study", Observation("printer2", "study", "printer")),
    ],
)
def test_an_observation_is_parsed_from_object_equals_room(text: str, expected: Observation) -> None:
    assert Observation.parse(text) == expected


@pytest.mark.parametrize("text", ["book1", "=kitchen", "book1=", ":book=kitchen", ""])
def test_a_malformed_observation_is_refused(text: str) -> None:
    with pytest.raises(InvalidValueError, match="write OBJECT=ROOM or OBJECT:CLASS=ROOM"):
        Observation.parse(text)


def test_an_answer_set_checks_its_steps_and_owns_its_json_shape() -> None:
    answer = KnowledgeBase(load_domain(PRINTER)).answer()
    assert answer.check_step(None) == answer.last_step == 2 and answer.check_step(1) == 1
    for step in (0, 3):
        with pytest.raises(InvalidValueError, match=r"^the domain has steps 1\.\.2$"):
            answer.check_step(step)
    data = answer.as_json(1)
    assert list(data) == ["step", "answer_sets", "holds", "ab"] and data["step"] == 1
    assert "holds(in(book1,study),1)" in data["holds"]["in"]
    assert answer.as_json()["step"] == 2


def test_a_knowledge_base_summary_owns_its_json_shape() -> None:
    kb = KnowledgeBase(load_domain(PRINTER))
    data = kb.summary().as_json()
    assert list(data) == [
        "domain",
        "files",
        "consistent",
        "answer_sets",
        "rooms",
        "classes",
        "objects",
        "located",
        "ground_seconds",
        "solve_seconds",
        "warnings",
    ]
    assert data["domain"] == kb.domain.name and data["files"] == [str(f) for f in kb.files]
    assert data["consistent"] is True and data["rooms"] == 3 and data["warnings"] == []


def test_the_package_ships_the_axioms_it_loads() -> None:
    """``pip install .`` (not editable) must still find the axioms: they are package data whose
    contents are the repository's hand-edited kb/ files."""
    from importlib import resources

    from beliefloc.knowledge.program import AXIOMS, ROBOT_AXIOMS

    for path in (AXIOMS, ROBOT_AXIOMS):
        shipped = resources.files("beliefloc.knowledge") / "lp" / path.name
        assert shipped.read_text() == (KB_DIR / path.name).read_text() == path.read_text()
