"""JSON-ready records: the ``to_dict`` that the application's plain result dataclasses share.

A result whose JSON form is its fields as they are (a check's :class:`~bodyvib.vehicle.check.Criterion`,
a run's :class:`~bodyvib.vehicle.road.driven.RunSettings`, :class:`~bodyvib.vehicle.road.driven.RoadOptions`,
:class:`~bodyvib.vehicle.road.iri.IriResult`) inherits :class:`Record`; one that changes a field on the
way out (:class:`~bodyvib.vehicle.road.classify.RoadClass`: an infinite limit as None) starts from
``super().to_dict()``.
"""

from dataclasses import asdict

__all__ = ["Record"]


class Record:
    """Mixin for a dataclass whose JSON form is its fields: ``to_dict()`` is ``asdict``.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Point(Record):
    ...     x_m: float
    ...     tags: tuple = ()
    >>> Point(1.5, ("a",)).to_dict()
    {'x_m': 1.5, 'tags': ('a',)}
    """

    __slots__ = ()

    def to_dict(self) -> dict:
        """The fields as a dict, nested dataclasses as dicts (:func:`dataclasses.asdict`).

        Returns
        -------
        dict
            Field name to value; ready for :func:`json.dumps` when the values are numbers,
            strings, None, lists, tuples or dicts of them.
        """
        return asdict(self)
