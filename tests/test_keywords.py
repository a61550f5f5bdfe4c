"""``-k EXPR`` of check and compare: pytest's keyword expressions over a scenario's path and name,
read by stackdsl's own parser (stackdsl/batch/keywords.py); a bad one is one line, exit 2."""

import pytest

from stackdsl.batch.keywords import KeywordError, parse_keywords
from stackdsl.cli.main import main

STANDS = "stackdsl: 1\nstructure: {tower: {levels: 1}}\ntiming: {settle: 0.2 s}\nexpect: {stands: true}\n"


@pytest.mark.parametrize(
    ("expression", "selected"),
    [
        ("", ["a/four_stack.yaml", "a/slant.yaml", "hard/slant.yaml"]),
        ("SLANT", ["a/slant.yaml", "hard/slant.yaml"]),
        ("slant and not hard/", ["a/slant.yaml"]),
        ("not (slant or four)", []),
        ("four or hard/", ["a/four_stack.yaml", "hard/slant.yaml"]),
        ("tower", ["a/four_stack.yaml"]),  # its name
        ("not not a/", ["a/four_stack.yaml", "a/slant.yaml"]),
    ],
)
def test_k_is_pytests_expression_over_the_path_and_the_name(expression, selected):
    scenarios = {"a/four_stack.yaml": "4 stack tower", "a/slant.yaml": "slant", "hard/slant.yaml": "slant"}
    keywords = parse_keywords(expression)
    assert [path for path, name in scenarios.items() if keywords.matches(path, name)] == selected


@pytest.mark.parametrize(
    ("expression", "said"),
    [
        ("a and", "at column 6: expected a word, 'not' or '(' after 'and'; got the end of the expression"),
        ("(a or b", "at column 8: expected ')' after 'b'; got the end of the expression"),
        ("a b", "at column 3: expected 'and', 'or' or the end; got 'b'"),
        ("a or or", "at column 6: expected a word, 'not' or '(' after 'or'; got 'or'"),
        ("a & b", "at column 3: '&' is in no word"),
        (")", "at column 1: expected a word, 'not' or '('; got ')'"),
    ],
)
def test_a_bad_k_expression_says_where(expression, said):
    with pytest.raises(KeywordError, match=None) as info:
        parse_keywords(expression)
    assert str(info.value).startswith(said)


def test_a_bad_k_expression_is_bad_input_in_one_line(tmp_path, capsys):
    (tmp_path / "a.yaml").write_text(STANDS)
    folder = tmp_path
    assert main(["check", str(folder), "-k", "a and (b", "-j", "1"]) == 2
    assert main(["compare", str(folder), "-k", "not", "-j", "1"]) == 2
    first, second = capsys.readouterr().err.splitlines()
    assert first == "-k: cannot read 'a and (b': at column 9: expected ')' after 'b'; got the end of the expression"
    assert second.startswith("-k: cannot read 'not': at column 4: expected a word")
