"""The immutable value classes (esair_min's Mark, STD's Sample and Spec) refuse both
assigning and deleting a field with AttributeError (deleting used to raise TypeError:
``__delattr__`` was ``__setattr__``, which needs a value)."""

import pytest

from esair_min.errors import Mark
from esair_std.sample import Sample
from esair_std.spec import Spec

VALUES = [(Mark("robot.yaml", 3, 5), "Mark"), (Sample(1.5, 1, 10.0, "sonar"), "Sample"),
          (Spec("behavior", "follow", "m:C"), "Spec")]


@pytest.mark.parametrize("value, cls", VALUES)
def test_a_field_cannot_be_assigned(value, cls):
    with pytest.raises(AttributeError) as exc:
        value.line = 4
    assert str(exc.value) == f"cannot assign to field 'line' of an immutable {cls}"


@pytest.mark.parametrize("value, cls", VALUES)
def test_a_field_cannot_be_deleted(value, cls):
    field = value.__slots__[0]
    with pytest.raises(AttributeError) as exc:
        delattr(value, field)
    assert str(exc.value) == f"cannot delete field {field!r} of an immutable {cls}"
    assert getattr(value, field) is not None
