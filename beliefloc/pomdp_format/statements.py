"""Tokenising a ``.pomdp`` file: its lines into :class:`Statement` and :class:`Comment` records.

A statement starts at a line whose first token is a statement keyword (``states``, ``T``, ...) and
runs until the next such line, so a matrix or a long list may span lines; ``:`` is a token of its
own. Comments run from ``#`` to the end of the line; only ``# beliefloc-...`` comments are kept.
This module also holds the readers every kind of statement uses: :func:`expect_colon` and
:func:`numbers`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from beliefloc.errors import ModelError
from beliefloc.pomdp_format.names import NUMBER

STATEMENTS = frozenset({"discount", "values", "states", "actions", "observations", "start", "T", "O", "R"})
"""The keywords that start a statement."""


def located(path: str, line: int, message: str) -> ModelError:
    """The error every problem of a file is: ``path:line: message``."""
    return ModelError(f"{path}:{line}: {message}")


@dataclass
class Statement:
    """One statement of file ``path``: its tokens (``:`` is a token) and the line of each token."""

    tokens: list[str]
    line: int
    path: str
    token_lines: list[int] | None = None
    """The line of every token, for a statement that spans lines (else every token is on ``line``)."""

    def line_at(self, i: int) -> int:
        """The line of token ``i`` (the last token's for ``i`` past the end)."""
        if self.token_lines is None or not self.token_lines:
            return self.line
        return self.token_lines[min(i, len(self.token_lines) - 1)]

    def head(self, end: int) -> str:
        """The statement's first tokens as written, e.g. ``T: go : a`` (for messages)."""
        return f"{self.tokens[0]}: {' '.join(self.tokens[2:end])}"

    def error(self, line: int, message: str) -> ModelError:
        return located(self.path, line, message)


@dataclass(frozen=True)
class Comment:
    """A ``# beliefloc-...`` comment: its text after ``#`` and its line."""

    text: str
    line: int
    path: str

    def error(self, message: str) -> ModelError:
        return located(self.path, self.line, message)


def tokenise(text: str, path: str) -> Iterator[Statement | Comment]:
    """The statements and beliefloc comments of ``text``, in the order they are complete.

    A comment is yielded as soon as its line is read, a statement only when the next one starts
    (or the file ends), so the consumer sees a comment on a statement's line before that statement
    and a stray token is refused only after every earlier comment was seen.
    """
    pending: list[tuple[list[str], int]] = []
    if "\r" in text:  # CR LF (Windows) and CR alone (classic Mac OS) end lines too
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    for lineno, raw_line in enumerate(text.split("\n"), 1):
        line = raw_line
        cut = line.find("#")
        if cut >= 0:
            comment = line[cut + 1 :].strip()
            if comment.startswith("beliefloc-"):
                yield Comment(comment, lineno, path)
            line = line[:cut]
        if ":" in line:
            line = line.replace(":", " : ")
        tokens = line.split()
        if not tokens:
            continue
        if tokens[0] in STATEMENTS:
            if pending:
                yield _statement(pending, path)
            pending = [(tokens, lineno)]
        elif pending:
            pending.append((tokens, lineno))
        else:
            raise located(
                path,
                lineno,
                f"expected a statement (discount:, values:, states:, actions:, observations:, start:, T:, O: "
                f"or R:), found {tokens[0]!r}",
            )
    if pending:
        yield _statement(pending, path)


def last_line(text: str) -> int:
    """The number of the file's last line (a final newline does not start another one)."""
    lines = text.count("\n") + 1
    return max(lines - 1 if text.endswith("\n") else lines, 1)


def _statement(pending: list[tuple[list[str], int]], path: str) -> Statement:
    """One statement from the tokens of its lines."""
    if len(pending) == 1:
        tokens, line = pending[0]
        return Statement(tokens, line, path)
    tokens, token_lines = [], []
    for chunk, line in pending:
        tokens.extend(chunk)
        token_lines.extend([line] * len(chunk))
    return Statement(tokens, pending[0][1], path, token_lines)


def expect_colon(st: Statement, i: int, after: str) -> None:
    """Refuse a statement whose token ``i`` is not ``:``."""
    if len(st.tokens) <= i or st.tokens[i] != ":":
        found = repr(st.tokens[i]) if len(st.tokens) > i else "the end of the statement"
        raise st.error(st.line_at(i), f"expected ':' after {after}, found {found}")


def numbers(st: Statement, start: int, count: int, what: str, *, signed: bool = False) -> np.ndarray:
    """The ``count`` numbers from token ``start`` to the end; ``signed`` joins a lone sign to its number."""
    tokens = st.tokens[start:]
    if signed and ("-" in tokens or "+" in tokens):  # '- 1.0' is a sign and a number
        tokens = _join_signs(tokens)
    if len(tokens) != count:
        where = st.line_at(start + count) if len(tokens) > count else st.line_at(len(st.tokens) - 1)
        raise st.error(where, f"{what} needs {count} number{'s' if count != 1 else ''}, found {len(tokens)}")
    for j, token in enumerate(tokens):
        if not NUMBER.match(token):
            raise st.error(st.line_at(start + j), f"{what}: expected a number, found {token!r}")
    return np.array(tokens, dtype=np.float64)


def _join_signs(tokens: list[str]) -> list[str]:
    out: list[str] = []
    sign = ""
    for token in tokens:
        if token in ("-", "+") and not sign:
            sign = token
            continue
        out.append(sign + token)
        sign = ""
    if sign:
        out.append(sign)
    return out
