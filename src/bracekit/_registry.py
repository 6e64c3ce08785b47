"""A registry of extension classes by a class-level name: objective terms by weight key, task shapes by kind."""

from __future__ import annotations

from typing import Generic, TypeVar

from bracekit._linalg import show
from bracekit.errors import InputError

__all__ = ["Registry"]

T = TypeVar("T", bound=type)


class Registry(dict[str, T], Generic[T]):
    """Name → class, filled by :meth:`register` (a class decorator) from each class's attribute ``attr``.

    ``what`` names the classes in messages ("objective term", "task shape") and ``label`` the attribute
    ("weight key", "kind"). A class without a name, or with one already taken, is refused (InputError).
    """

    def __init__(self, what: str, attr: str, label: str) -> None:
        super().__init__()
        self.what, self.attr, self.label = what, attr, label

    def register(self, cls: T) -> T:
        """Class decorator: make ``cls`` available under its name."""
        name = getattr(cls, self.attr)
        if not name or name in self:
            raise InputError(f"{self.what} {cls.__name__} needs a unique {self.label}, got {show(name)}")
        self[name] = cls
        return cls
