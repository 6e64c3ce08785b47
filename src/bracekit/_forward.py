"""A read-only attribute read through a member: the typed form of a property that only forwards."""

from __future__ import annotations

from typing import Any, Generic, TypeVar, cast, overload

T = TypeVar("T")


class Forward(Generic[T]):
    """``name = Forward[T]("member", "doc")`` in a class body: ``obj.name`` is ``obj.member.name`` (read-only).

    The views of the model (the chain split, the holding report) expose their members' quantities under the
    same names; this says so once instead of one property each.
    """

    def __init__(self, member: str, doc: str) -> None:
        self.member = member
        self.name = ""
        self.__doc__ = doc

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> Forward[T]: ...
    @overload
    def __get__(self, obj: object, owner: type | None = None) -> T: ...
    def __get__(self, obj: object | None, owner: type | None = None) -> Forward[T] | T:
        if obj is None:
            return self
        return cast(T, getattr(getattr(obj, self.member), self.name))

    def __set__(self, obj: Any, value: Any) -> None:
        raise AttributeError(f"{self.name} is read-only (it is {self.member}.{self.name})")
