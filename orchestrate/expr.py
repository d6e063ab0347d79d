"""Load expressions of scenes: a whitelist parser.

A scene gives loads and prescribed displacements as expressions in x, y, t, and position-dependent
initial data (ζ⁰, β⁰) as expressions in x, y. They reach FreeFEM
only through this module: the text is tokenized and parsed into a tree by the grammar below, and
FreeFEM code is written from the tree, never from the text. Anything outside the grammar is
refused with the position and what was allowed, before FreeFem++ starts.

    expression := sum [comparison sum]          comparison: <  <=  >  >=  ==  !=
    sum        := product {(+ | -) product}
    product    := unary {(* | /) unary}
    unary      := (+ | -) unary | power
    power      := atom [^ unary]                 right-associative; -x^2 is -(x^2)
    atom       := number | x | y | t | function(expression {, expression}) | (expression)

Numbers are written to FreeFEM as reals (FreeFEM divides integers as integers); a comparison is
1 where it holds and 0 elsewhere, so (x <= 3)*(-10*t) is a load on part of a boundary.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

VARIABLES = ("x", "y", "t")
# name: number of arguments
FUNCTIONS = {"sin": 1, "cos": 1, "tan": 1, "asin": 1, "acos": 1, "atan": 1, "sinh": 1, "cosh": 1,
             "tanh": 1, "exp": 1, "log": 1, "log10": 1, "sqrt": 1, "abs": 1, "floor": 1, "ceil": 1,
             "min": 2, "max": 2, "pow": 2, "atan2": 2}
COMPARISONS = ("<=", ">=", "==", "!=", "<", ">")
MAX_LENGTH = 2000
MAX_DEPTH = 64  # parentheses, calls, signs and powers nested
MAX_TREE_DEPTH = 200  # and the tree with its chains (a+b+c is a tree two deep): code is written from it recursively

TOKEN = re.compile(r"\s*(?:(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
                   r"|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
                   r"|(?P<op><=|>=|==|!=|[-+*/^(),<>]))")


class ExpressionError(ValueError):
    """An expression outside the whitelist grammar."""

    def __init__(self, text: str, position: int, problem: str, variables: tuple[str, ...] = VARIABLES):
        self.text, self.position, self.problem = text, position, problem
        shown = text if len(text) <= 80 else text[:77] + "..."
        super().__init__(f"{problem} at position {position} of '{shown}' (allowed: numbers, {', '.join(variables)}, "
                         f"+ - * / ^, parentheses, comparisons, and {', '.join(sorted(FUNCTIONS))})")


@dataclass(frozen=True)
class Number:
    value: float


@dataclass(frozen=True)
class Variable:
    name: str


@dataclass(frozen=True)
class Unary:
    op: str
    operand: object


@dataclass(frozen=True)
class Binary:
    op: str
    left: object
    right: object


@dataclass(frozen=True)
class Call:
    function: str
    arguments: tuple


def tokenize(text: str) -> list[tuple[str, str, int]]:
    """(kind, token, position) for each token; refuses any character the grammar does not know."""
    if len(text) > MAX_LENGTH:
        raise ExpressionError(text[:MAX_LENGTH], MAX_LENGTH, f"expression longer than {MAX_LENGTH} characters")
    tokens, position = [], 0
    while position < len(text):
        if text[position:].strip() == "":
            break
        match = TOKEN.match(text, position)
        if match is None or match.end() == position:
            start = position + len(text[position:]) - len(text[position:].lstrip())
            raise ExpressionError(text, start, f"character {text[start]!r} is not allowed")
        kind = match.lastgroup
        tokens.append((kind, match.group(kind), match.start(kind)))
        position = match.end()
    return tokens


class Parser:
    def __init__(self, text: str, variables: tuple[str, ...] = VARIABLES):
        self.text, self.variables = text, variables
        self.tokens = tokenize(text)
        self.index = 0
        self.depth = 0

    def peek(self) -> tuple[str, str, int] | None:
        return self.tokens[self.index] if self.index < len(self.tokens) else None

    def fail(self, problem: str):
        token = self.peek()
        raise ExpressionError(self.text, token[2] if token else len(self.text), problem, self.variables)

    def take(self, token: str):
        current = self.peek()
        if current is None or current[1] != token:
            self.fail(f"expected '{token}'" + (f", found '{current[1]}'" if current else " at the end"))
        self.index += 1

    def parse(self):
        if not self.tokens:
            self.fail("empty expression")
        tree = self.expression()
        if self.peek() is not None:
            self.fail(f"unexpected '{self.peek()[1]}'")
        if tree_depth(tree) > MAX_TREE_DEPTH:
            raise ExpressionError(self.text, 0, f"expression deeper than {MAX_TREE_DEPTH} operations in a chain",
                                  self.variables)
        bad = not_finite(tree)
        if bad is not None:
            raise ExpressionError(self.text, 0, f"a part of it, {to_freefem(bad)}, is not a finite number", self.variables)
        return tree

    def deeper(self):
        """Every rule that recurses counts its depth: a tree deeper than MAX_DEPTH is refused
        before Python's own recursion limit is reached."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            self.fail(f"expression nested deeper than {MAX_DEPTH}")

    def expression(self):
        self.deeper()
        left = self.sum()
        token = self.peek()
        if token and token[1] in COMPARISONS:
            self.index += 1
            left = Binary(token[1], left, self.sum())
        self.depth -= 1
        return left

    def sum(self):
        left = self.product()
        while (token := self.peek()) and token[1] in "+-":
            self.index += 1
            left = Binary(token[1], left, self.product())
        return left

    def product(self):
        left = self.unary()
        while (token := self.peek()) and token[1] in ("*", "/"):
            self.index += 1
            right = self.unary()
            if token[1] == "/" and constant(right) == 0:  # FreeFEM stops on it, or crashes inside an interpolation
                raise ExpressionError(self.text, token[2], "division by zero (the divisor is 0 everywhere)",
                                      self.variables)
            left = Binary(token[1], left, right)
        return left

    def unary(self):
        token = self.peek()
        if token and token[1] in ("+", "-"):
            self.index += 1
            self.deeper()
            operand = self.unary()
            self.depth -= 1
            return operand if token[1] == "+" else Unary("-", operand)
        return self.power()

    def power(self):
        base = self.atom()
        if (token := self.peek()) and token[1] == "^":
            self.index += 1
            self.deeper()
            exponent = self.unary()
            self.depth -= 1
            return Binary("^", base, exponent)
        return base

    def atom(self):
        token = self.peek()
        if token is None:
            self.fail("expression ends too early")
        kind, text, _ = token
        if kind == "number":
            value = float(text)
            if not math.isfinite(value):
                self.fail(f"number {text} is not finite")
            self.index += 1
            return Number(value)
        if kind == "name":
            self.index += 1
            if text in self.variables:
                return Variable(text)
            if text not in FUNCTIONS:
                self.index -= 1
                self.fail(f"name '{text}' is not allowed")
            self.take("(")
            arguments = [self.expression()]
            while (current := self.peek()) and current[1] == ",":
                self.index += 1
                arguments.append(self.expression())
            self.take(")")
            if len(arguments) != FUNCTIONS[text]:
                self.index -= 1
                self.fail(f"{text} takes {FUNCTIONS[text]} argument(s), got {len(arguments)}")
            return Call(text, tuple(arguments))
        if text == "(":
            self.index += 1
            inner = self.expression()
            self.take(")")
            return inner
        self.fail(f"unexpected '{text}'")


def children(tree) -> tuple:
    if isinstance(tree, Unary):
        return (tree.operand,)
    if isinstance(tree, Binary):
        return (tree.left, tree.right)
    if isinstance(tree, Call):
        return tree.arguments
    return ()


def tree_depth(tree) -> int:
    """The depth of a tree, without recursion (a long chain a+b+c+... is deep)."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack += [(child, depth + 1) for child in children(node)]
    return deepest


def has_variable(tree) -> bool:
    return isinstance(tree, Variable) or any(has_variable(child) for child in children(tree))


def constant(tree) -> float | None:
    """The value of a tree without variables (nan where Python's math refuses it), else None."""
    if has_variable(tree):
        return None
    try:
        return evaluate(tree, 0.0, 0.0, 0.0)
    except (ArithmeticError, ValueError):  # division by zero, log(0), sqrt(-1), an overflow
        return math.nan


def not_finite(tree):
    """The first part of a tree without variables whose value is not a finite number, or None."""
    value = constant(tree)
    if value is not None:
        return tree if not math.isfinite(value) else None
    return next((bad for child in children(tree) if (bad := not_finite(child)) is not None), None)


def parse(text: str, variables: tuple[str, ...] = VARIABLES):
    """The syntax tree of an expression in `variables` (a subset of x, y, t), or ExpressionError."""
    if not isinstance(text, str):
        raise ExpressionError(repr(text), 0, f"an expression must be a string, got {type(text).__name__}", variables)
    return Parser(text, variables).parse()


def number_code(value: float) -> str:
    """A finite number as a FreeFEM real literal (always with a point or an exponent)."""
    code = repr(float(value))
    return code if any(c in code for c in ".e") else code + "."


def to_freefem(tree) -> str:
    """FreeFEM code for a syntax tree, fully parenthesized."""
    if isinstance(tree, Number):
        return f"({number_code(tree.value)})"
    if isinstance(tree, Variable):
        return tree.name
    if isinstance(tree, Unary):
        return f"(-{to_freefem(tree.operand)})"
    if isinstance(tree, Binary):
        left, right = to_freefem(tree.left), to_freefem(tree.right)
        if tree.op in COMPARISONS:
            return f"(({left} {tree.op} {right}) ? 1. : 0.)"
        return f"({left} {tree.op} {right})"
    if isinstance(tree, Call):
        return f"{tree.function}({', '.join(to_freefem(a) for a in tree.arguments)})"
    raise TypeError(f"not an expression tree: {tree!r}")


def freefem(text: str) -> str:
    """Parse a scene expression and return its FreeFEM code."""
    return to_freefem(parse(text))


def is_zero(text: str) -> bool:
    """True when the expression is the number 0 (a term that needs no code)."""
    tree = parse(text)
    return isinstance(tree, Number) and tree.value == 0


def evaluate(tree, x: float, y: float, t: float) -> float:
    """The value of a syntax tree (for tests: FreeFEM must compute the same)."""
    if isinstance(tree, Number):
        return tree.value
    if isinstance(tree, Variable):
        return {"x": x, "y": y, "t": t}[tree.name]
    if isinstance(tree, Unary):
        return -evaluate(tree.operand, x, y, t)
    if isinstance(tree, Call):
        values = [evaluate(a, x, y, t) for a in tree.arguments]
        functions = {"abs": abs, "min": min, "max": max, "pow": math.pow, "log": math.log}
        return float(functions.get(tree.function, getattr(math, tree.function, None))(*values))
    a, b = evaluate(tree.left, x, y, t), evaluate(tree.right, x, y, t)
    operations = {"+": a + b, "-": a - b, "*": a * b}
    if tree.op in operations:
        return operations[tree.op]
    if tree.op == "/":
        return a / b
    if tree.op == "^":
        return math.pow(a, b)
    return float({"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "==": a == b, "!=": a != b}[tree.op])
