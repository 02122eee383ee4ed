"""``ogacq.io.declared``: a JSON value checked against its annotation, each refusal
naming the key and saying what the value must be and what it was. The reader of an
annotation is built once (a session's thousands of lines check the same few)."""

from __future__ import annotations

from typing import Any

import pytest

from ogacq.io.declared import Finite, checked, reader

Triple = tuple[Finite, Finite, Finite]


def refusal(key: str, problem: str) -> ValueError:
    return ValueError(f"{key}: {problem}")


def nested(hint: Any, value: Any, key: str) -> Any:
    return ("read", hint.__name__, value, key)


class Inner:
    pass


@pytest.mark.parametrize(("hint", "value", "said"), [
    (float, True, "k: must be a number, got true or false (True)"),
    (int, 2**63, "k: must be a whole number, got a number (9223372036854775808)"),
    (int, 1.0, "k: must be a whole number, got a number (1.0)"),
    (str, None, "k: must be text, got null (None)"),
    (bool, 1, "k: must be true or false, got a number (1)"),
    (Finite, float("nan"), "k: must be a finite number, got a number (nan)"),
    (Finite | None, float("inf"), "k: must be a finite number, got a number (inf)"),
    (Triple, [1.0, 2.0], "k: must be a list of 3, got a list ([1.0, 2.0])"),
    (Triple, [1.0, "2", 3.0], "k[1]: must be a number, got text ('2')"),
    (tuple[int, ...], {"a": 1}, "k: must be a list, got an object ({'a': 1})"),
    (tuple[int, ...], [1, 2, None], "k[2]: must be a whole number, got null (None)"),
    (dict[str, Finite], [1.0], "k: must be an object, got a list ([1.0])"),
    (dict[str, tuple[Finite, ...]], {"y_x": [1.0, 1e400]},
     "k.y_x[1]: must be a finite number, got a number (inf)"),
    (int, "x" * 60, "k: must be a whole number, got text ('" + "x" * 39 + "...)"),
])
def test_a_value_of_another_type_is_refused_naming_its_key_and_both_types(hint, value, said):
    for _ in range(2):  # the reader built, then the same reader again
        with pytest.raises(ValueError) as refused:
            checked(hint, value, "k", refusal, nested)
        assert str(refused.value) == said


@pytest.mark.parametrize(("hint", "value", "read"), [
    (float, 1, 1), (float | None, None, None), (Any, {"a": [1]}, {"a": [1]}),
    (Triple, [1, 2.5, 3], (1, 2.5, 3)), (tuple[tuple[int, str], ...], [[1, "a"]], ((1, "a"),)),
    (dict[str, int | None], {"a": None, "b": 2}, {"a": None, "b": 2}),
    (tuple[Inner, ...], ["v"], (("read", "Inner", "v", "k[0]"),)),
])
def test_a_value_of_its_type_is_read_as_declared(hint, value, read):
    assert checked(hint, value, "k", refusal, nested) == read


def test_each_annotation_is_read_once_into_its_reader():
    assert reader(Triple | None) is reader(Triple | None)
    assert reader(dict[str, Finite]) is reader(dict[str, Finite])
