"""The whitelist parser of load expressions (orchestrate/expr.py).

Three independent checks: trees printed by this test's own printer parse back to themselves;
whatever text comes in, what reaches FreeFEM is made of whitelisted tokens only; and FreeFEM
computes the same values as a plain Python evaluation of the tree."""
import math
import re

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from orchestrate import expr
from orchestrate.expr import Binary, Call, ExpressionError, Number, Unary, Variable
from orchestrate.freefem import run_script


SAFE_FUNCTIONS = ("sin", "cos", "atan", "tanh", "abs", "floor", "ceil", "min", "max", "exp")


def to_text(tree) -> str:
    """This test's printer: every operation in parentheses."""
    if isinstance(tree, Number):
        return repr(tree.value)
    if isinstance(tree, Variable):
        return tree.name
    if isinstance(tree, Unary):
        return f"(-{to_text(tree.operand)})"
    if isinstance(tree, Binary):
        return f"({to_text(tree.left)} {tree.op} {to_text(tree.right)})"
    return f"{tree.function}({', '.join(to_text(a) for a in tree.arguments)})"


def trees(functions=tuple(expr.FUNCTIONS)):
    leaves = st.one_of(st.floats(min_value=0, max_value=1e6, allow_nan=False).map(Number),
                       st.sampled_from(expr.VARIABLES).map(Variable))

    def extend(children):
        calls = st.sampled_from(functions).flatmap(
            lambda name: st.tuples(*[children] * expr.FUNCTIONS[name]).map(lambda args: Call(name, args)))
        return st.one_of(children.map(lambda c: Unary("-", c)),
                         st.tuples(st.sampled_from(["+", "-", "*", "/", "^", *expr.COMPARISONS]), children, children)
                         .map(lambda t: Binary(*t)),
                         calls)

    return st.recursive(leaves, extend, max_leaves=12)


@pytest.mark.unit
@given(trees())
def test_printed_trees_parse_back_to_themselves(tree):
    """Or are refused for a constant part that is not a finite number (a divisor 0 among them)."""
    try:
        parsed = expr.parse(to_text(tree))
    except ExpressionError as error:
        assert "division by zero" in str(error) or "is not a finite number" in str(error)
        assert expr.not_finite(tree) is not None or any(
            isinstance(part, Binary) and part.op == "/" and expr.constant(part.right) == 0 for part in parts(tree))
        return
    assert parsed == tree


def parts(tree):
    return [tree, *(part for child in expr.children(tree) for part in parts(child))]


ALLOWED_CODE = re.compile(r"[\sA-Za-z0-9_.()+\-*/^<>=!,?:]*")
ALLOWED_NAMES = set(expr.VARIABLES) | set(expr.FUNCTIONS) | {"e"}


@pytest.mark.unit
@given(st.text(max_size=60))
def test_any_text_is_refused_or_becomes_whitelisted_code(text):
    try:
        code = expr.freefem(text)
    except ExpressionError:
        return
    assert ALLOWED_CODE.fullmatch(code)
    assert set(re.findall(r"[A-Za-z_][A-Za-z_0-9]*", re.sub(r"\d+\.?\d*e[+-]?\d+", "", code))) <= ALLOWED_NAMES


@pytest.mark.unit
@given(st.text(alphabet="xyt0123456789.+-*/^()<>=!, sincoexpabmd", max_size=40))
def test_near_miss_text_is_refused_or_becomes_whitelisted_code(text):
    test_any_text_is_refused_or_becomes_whitelisted_code.hypothesis.inner_test(text)


def python_value(tree, point):
    try:
        value = expr.evaluate(tree, *point)
    except (ZeroDivisionError, OverflowError, ValueError):
        return None
    return value if math.isfinite(value) and abs(value) < 1e12 else None


def divides_by_zero(tree, point) -> bool:
    """True when a division anywhere in the tree has a zero denominator at the point."""
    if isinstance(tree, Binary):
        if tree.op == "/" and python_value(tree.right, point) in (0.0, None):
            return True
        return divides_by_zero(tree.left, point) or divides_by_zero(tree.right, point)
    if isinstance(tree, Unary):
        return divides_by_zero(tree.operand, point)
    if isinstance(tree, Call):
        return any(divides_by_zero(a, point) for a in tree.arguments)
    return False


POINTS = [(0.3, -1.7, 0.25), (2.0, 0.5, 1.0), (-1.25, 3.0, 0.0)]


@pytest.mark.solver
@settings(max_examples=6, deadline=None)
@given(st.lists(trees(SAFE_FUNCTIONS), min_size=12, max_size=12))
def test_freefem_computes_what_the_tree_means(tmp_path_factory, batch):
    cases = [(tree, point, python_value(tree, point)) for tree in batch for point in POINTS]
    cases = [(tree, point, value) for tree, point, value in cases
             if value is not None and not divides_by_zero(tree, point)
             and all(python_value(sub, point) is not None for sub in subtrees(tree))]
    assume(cases)
    lines = ["real t = 0;", "cout.precision(17);"]
    for i, (tree, (x, y, t), _) in enumerate(cases):
        lines += [f"t = {t!r};", f"func f{i} = {expr.to_freefem(tree)} + 0*x;",  # + 0*x: a field even when constant
                   f'cout << "v{i} " << f{i}({x!r}, {y!r}) << endl;']
    script = tmp_path_factory.mktemp("expr") / "values.edp"
    script.write_text("\n".join(lines) + "\n")
    done = run_script(script)
    assert done.returncode == 0, done.stdout[-2000:]
    values = dict(line.split() for line in done.stdout.splitlines() if line.startswith("v"))
    for i, (tree, point, expected) in enumerate(cases):
        assert float(values[f"v{i}"]) == pytest.approx(expected, rel=1e-12, abs=1e-12), (to_text(tree), point)


def subtrees(tree):
    yield tree
    for child in getattr(tree, "arguments", ()) or [getattr(tree, name) for name in ("operand", "left", "right")
                                                    if hasattr(tree, name)]:
        yield from subtrees(child)


@pytest.mark.parametrize("text, code", [
    ("-10*t", "((-(10.0)) * t)"),
    ("1/2", "((1.0) / (2.0))"),
    ("x <= 3", "((x <= (3.0)) ? 1. : 0.)"),
    ("-x^2", "(-(x ^ (2.0)))"),
    ("2^3^2", "((2.0) ^ ((3.0) ^ (2.0)))"),
])
@pytest.mark.unit
def test_precedence_and_real_literals(text, code):
    assert expr.freefem(text) == code


INJECTIONS = [
    'exec("rm -rf /")', "x); exec(\"ls\"); (1", 'sin(x)); exec("id"', 'include "/etc/passwd"',
    'load "shell"', '"', "x // comment", "x /* comment */", "macro y 1 //", "x; cout << 1",
    "ARGV[0]", "t#x", "Stringification(x)", "../../etc/passwd", "x\nmacro y", "system(1)",
    "x $ y", "x ; y", "x{1}", "sqrt(x", "sin x", "exp(1, 2)", "1e999", "x y", "\u0078", "ｘ",
    "x`id`", "x && y", "x || y", "!x", "x ? 1 : 0", "int2d(Th1)(1)", "Th1", "on(1, ux = 0)",
    "x = 1", "x += 1", "'a'", "\\", "func f = 1", "", "   ", "(" * 70 + "x" + ")" * 70,
]


@pytest.mark.unit
@pytest.mark.parametrize("text", INJECTIONS)
def test_injection_attempts_are_refused(text):
    if text == "\u0078":  # the escape is just "x": allowed, and harmless
        assert expr.freefem(text) == "x"
        return
    with pytest.raises(ExpressionError):
        expr.freefem(text)


@pytest.mark.unit
def test_error_names_the_position_and_the_allowed_tokens():
    with pytest.raises(ExpressionError) as error:
        expr.freefem("10*t + exec(1)")
    message = str(error.value)
    assert "'exec' is not allowed" in message and "position 7" in message and "sqrt" in message


@pytest.mark.unit
@pytest.mark.parametrize("text", ["0/0", "x/0", "1/0*t", "x/(1-1)", "t/(2-2)"])
def test_a_division_by_a_zero_constant_is_refused_where_it_is(text):
    """FreeFEM stops on a real division by 0 ("Div by 0", exit 8) or crashes inside an
    interpolation (SIGSEGV): the scene says so first, at the '/'."""
    with pytest.raises(ExpressionError, match=f"division by zero .* at position {text.index('/')} "):
        expr.parse(text)


@pytest.mark.parametrize("text, part", [("1e308*10", "((1e+308) * (10.0))"), ("log(0)", "log((0.0))"),
                                        ("sqrt(-1) + x", "sqrt((-(1.0)))"), ("2^2000*t", "((2.0) ^ (2000.0))")])
@pytest.mark.unit
def test_a_constant_part_that_is_not_a_finite_number_is_refused_naming_it(text, part):
    with pytest.raises(ExpressionError, match=re.escape(f"{part}, is not a finite number")):
        expr.parse(text)


@pytest.mark.unit
@given(tree=trees())
def test_a_tree_accepted_has_only_finite_constant_parts(tree):
    try:
        parsed = expr.parse(to_text(tree))
    except ExpressionError:
        return
    for part in parts(parsed):
        value = expr.constant(part)
        assert value is None or math.isfinite(value)
