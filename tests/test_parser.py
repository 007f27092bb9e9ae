"""The reader: Prolog syntax, event operators, and error positions."""
import pytest

from retalisc.frontend.errors import RetalisSyntaxError
from retalisc.frontend.parser import read_program, read_term
from retalisc.frontend.terms import to_prolog


def term(text):
    return read_term(text)


@pytest.mark.parametrize("text, expected", [
    ("a :- b, c ; d -> e", ":-(a, ;(','(b, c), ->(d, e)))"),
    ("X is -1 + 2 * 3", "is(X, +((-1), *(2, 3)))"),
    ("Y = - 1", "=(Y, -(1))"),
    ("Z = -(1)", "=(Z, -(1))"),
    ("- - a", "-(-(a))"),
    ("a - -1", "-(a, (-1))"),
    ("\\+ a = b", "\\+(=(a, b))"),
    ("f(a, [1, 2|T], 'hello world', \"str\", 0'a, 1.5e3)", "f(a, [1, 2|T], 'hello world', \"str\", 97, 1500.0)"),
    ("X = f(- , a)", "=(X, f(-, a))"),
    ("a:b:c", ":(a, :(b, c))"),
    ("{a, b}", "{','(a, b)}"),
    ("[]", "[]"),
    ("'it''s'", "'it\\'s'"),
    ("0x1F + 0b101 + 0o17", "+(+(31, 5), 15)"),
    ("E^[T1, T2]", "^(E, [T1, T2])"),
    ("D is (X-1)*(X-1)", "is(D, *(-(X, 1), -(X, 1)))"),
    ("X = (a)-(b)-(c)", "=(X, -(-(a, b), c))"),
    ("f(-(1))", "f(-(1))"),
])
def test_prolog_terms(text, expected):
    assert to_prolog(term(text)) == expected


@pytest.mark.parametrize("text, expected", [
    ("h <- a seq b seq c", "<-(h, seq(seq(a, b), c))"),
    ("h <- a or b and c seq d", "<-(h, or(a, and(b, seq(c, d))))"),
    ("h <- a 'seq' b", "<-(h, seq(a, b))"),
    ("h <- (a and b where x(A), y(B)).300", "<-(h, '.'(where(and(a, b), ','(x(A), y(B))), 300))"),
    ("h <- not(c).[a, b]", "<-(h, '.'(not(c), [a, b]))"),
    ("h <- (a seq b) cnot c", "<-(h, cnot(seq(a, b), c))"),
    ("r1 'rule:' h <- a", "'rule:'(r1, <-(h, a))"),
    ("h do (write(x), nl) <- a", "<-(do(h, ','(write(x), nl)), a)"),
    ("h <- a par b equals c meets d during e starts f finishes g",
     "<-(h, par(a, finishes(starts(during(meets(equals(b, c), d), e), f), g)))"),
])
def test_event_operators(text, expected):
    assert to_prolog(term(text)) == expected


def test_comments_and_positions():
    clauses = read_program("% line comment\n/* block\n comment */ a.\n\n  b(X) :-\n    c(X).\n", "f.rtl")
    assert [to_prolog(c.term) for c in clauses] == ["a", ":-(b(X), c(X))"]
    assert (clauses[0].span.line, clauses[0].span.column) == (3, 13)
    assert (clauses[1].span.line, clauses[1].span.column) == (5, 3)


def test_op_directive_applies_to_later_clauses():
    clauses = read_program(":- op(700, xfx, ===>).\na ===> b.\n", "f.rtl")
    assert to_prolog(clauses[1].term) == "===>(a, b)"


@pytest.mark.parametrize("text, line, column, message", [
    ("a(X) :- b(X\n", 1, 12, "missing '.'"),
    ("a :- b c.\n", 1, 8, "operator expected"),
    ("ok.\nh <- a SEQ b.\n", 2, 8, "write the event operator in lowercase: 'seq'"),
    ("a :- 'unterminated.\n", 1, 6, "unexpected character"),
    ("a :- b)).\n", 1, 7, "unexpected ')'"),
])
def test_syntax_errors_have_positions(text, line, column, message):
    with pytest.raises(RetalisSyntaxError) as info:
        read_program(text, "bad.rtl")
    error = info.value
    assert (error.span.line, error.span.column) == (line, column)
    assert message in error.message
    rendered = error.render(text)
    assert rendered.startswith(f"bad.rtl:{line}:{column}: syntax error:")
    assert rendered.splitlines()[2].strip() == "^"


@pytest.mark.parametrize("text, expected", [
    ("h(X) <- a(X) 'SEQ' b(X) 'AND' c 'WHERE' X > 1.", "<-(h(X), where(and(seq(a(X), b(X)), c), >(X, 1)))"),
    ("h <- a 'OR' b 'PAR' c 'CNOT' d.", "<-(h, or(a, par(b, cnot(c, d))))"),
    ("h <- a 'Seq' b 'Equals' c 'FNOT' d.", "<-(h, fnot(equals(seq(a, b), c), d))"),
    ("h 'DO' true <- a 'CHECK' t1(_) 'DURING' b.", "<-(do(h, true), check(a, during(t1(_), b)))"),
    ("x :- X = 'SEQ', Y = seq('SEQ').", ":-(x, ','(=(X, 'SEQ'), =(Y, seq('SEQ'))))"),
])
def test_quoted_capitalised_etalis_operators(text, expected):
    """'SEQ', 'Seq', 'AND', ... are the lowercase operators (same priorities); as operands
    they stay atoms."""
    assert to_prolog(read_program(text + "\n", "f.rtl")[0].term) == expected


@pytest.mark.parametrize("text, expected", [
    ("x :- ins_event_rule(d(Y) <- c(Y)).", ":-(x, ins_event_rule(<-(d(Y), c(Y))))"),
    ("x :- f(a :- b, c), g([h <- i, j]).", ":-(x, ','(f(:-(a, b), c), g([<-(h, i), j])))"),
    ("x :- del_event_rule(r1 'rule:' h <- a).", ":-(x, del_event_rule('rule:'(r1, <-(h, a))))"),
])
def test_arguments_up_to_priority_1200_as_swi_prolog_reads_them(text, expected):
    assert to_prolog(read_program(text + "\n", "f.rtl")[0].term) == expected
