"""The statements of a ``.pomdp`` file, read into a :class:`ParsedFile`: plain records, no model yet.

:func:`parse_statements` hands each statement to its reader -- the header to
:mod:`~beliefloc.pomdp_format.preamble`, ``T:`` and ``O:`` to :mod:`~beliefloc.pomdp_format.tables`,
``R:`` to :mod:`~beliefloc.pomdp_format.rewards`, the beliefloc comments to
:mod:`~beliefloc.pomdp_format.comments` -- in file order (a comment as soon as its line is read, a
statement once it is complete), so a statement is read with everything declared before it.
:mod:`~beliefloc.pomdp_format.build` then makes the model and checks what needs the whole file.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from beliefloc.errors import ModelError
from beliefloc.pomdp_format.comments import Annotations, read_comment
from beliefloc.pomdp_format.names import KINDS
from beliefloc.pomdp_format.preamble import Preamble
from beliefloc.pomdp_format.rewards import Reward, read_reward
from beliefloc.pomdp_format.statements import Comment, Statement, last_line, located, tokenise
from beliefloc.pomdp_format.tables import Entries, read_table


@dataclass
class Body:
    """What the ``T:``, ``O:`` and ``R:`` statements give, per action."""

    line: int
    """The line of the first of them."""
    transitions: list[Entries]
    observations: list[Entries]
    rewards: list[list[Reward]]


@dataclass
class ParsedFile:
    """Everything a ``.pomdp`` file says, as read: the preamble, the body and the beliefloc comments."""

    path: str
    preamble: Preamble = field(default_factory=Preamble)
    notes: Annotations = field(default_factory=Annotations)
    body: Body | None = None
    """None until the first ``T:``, ``O:`` or ``R:``."""
    last_line: int = 1

    def error(self, line: int, message: str) -> ModelError:
        return located(self.path, line, message)

    def begin_body(self, head: str, line: int, statement: Statement | None = None) -> Body:
        """The body; statement ``head`` on ``line`` starts it if it is the first ``T:``, ``O:`` or ``R:``.

        The body is sized by the declarations, so they must all come first, and are checked against
        the limits before it is made.
        """
        if self.body is None:
            missing = [k for k in KINDS if k not in self.preamble.declared]
            if missing:
                raise self.error(
                    line,
                    f"{head}: comes before the preamble declared {', '.join(m + ':' for m in missing)}; "
                    "the preamble (discount:, values:, states:, actions:, observations:) must come first",
                )
            n_actions = self.preamble.size("actions")
            self.preamble.check_sizes(statement or Statement([head], line, self.path))
            self.body = Body(
                line,
                transitions=[Entries() for _ in range(n_actions)],
                observations=[Entries() for _ in range(n_actions)],
                rewards=[[] for _ in range(n_actions)],
            )
        return self.body


def parse_statements(text: str, path: str) -> ParsedFile:
    """Read every statement and beliefloc comment of ``text`` (the file ``path``)."""
    parsed = ParsedFile(path)
    for item in tokenise(text, path):
        if isinstance(item, Comment):
            read_comment(parsed.notes, item)
        else:
            _read_statement(parsed, item)
    parsed.last_line = last_line(text)
    return parsed


def _read_statement(parsed: ParsedFile, st: Statement) -> None:
    head = st.tokens[0]
    preamble = parsed.preamble
    if head in ("T", "O", "R"):
        body = parsed.begin_body(head, st.line, st)
        actions = preamble.actions_of(st)
        if head == "R":
            reward = read_reward(st, preamble)
            for a in actions:
                body.rewards[a].append(reward)
        else:
            read_table(st, preamble, actions, body.transitions if head == "T" else body.observations)
    elif head in KINDS:
        if parsed.body is not None:
            raise st.error(st.line, f"{head}: must come before the first T:, O: or R: (line {parsed.body.line})")
        preamble.declare(st, head)
    elif head == "discount":
        preamble.discount(st)
    elif head == "values":
        preamble.values(st)
    else:
        preamble.start_belief(st)
