"""What a primitive acts on, in words: one wording for ``library list`` and the web view.

Kept here, below every layer, so that the commands that only list a library import no heavy package.
"""

from __future__ import annotations

__all__ = ["describe_relation"]


def describe_relation(acts) -> str:
    """What a primitive acts on, in words, from :meth:`Relation.to_dict` (or None: ``""``).

    ``"carries handle about 2 joint(s): turned 1.38 rad in door, turned 0.393 rad in world"``,
    ``"carries cube to plate"``, ``"ends at pot (0.170 m)"``: as ``library list`` and the web view say it.

    Examples
    --------
    >>> describe_relation({"object": "pot", "moves_with": False, "distance": 0.17, "target": None})
    'ends at pot (0.170 m)'
    >>> describe_relation({"object": "handle", "moves_with": True, "target": None,
    ...                    "joints": [{"kind": "revolute", "in": "door", "value": 1.38}]})
    'carries handle about 1 joint(s): turned 1.38 rad in door'
    """
    if not isinstance(acts, dict) or not acts.get("object"):
        return ""
    if not acts.get("moves_with"):
        far = acts.get("distance")
        return f"ends at {acts['object']}" + (f" ({far:.3f} m)" if isinstance(far, int | float) else "")
    to = f" to {acts['target']}" if acts.get("target") else ""
    joints = [j for j in acts.get("joints") or []
              if isinstance(j, dict) and {"kind", "value", "in"} <= set(j)]
    said = [f"{'turned' if j['kind'] == 'revolute' else 'slid'} {abs(float(j['value'])):.3g} "
            f"{'rad' if j['kind'] == 'revolute' else 'm'} in {j['in']}" for j in joints]
    about = f" about {len(joints)} joint(s): " + ", ".join(said) if joints else ""
    return f"carries {acts['object']}{to}{about}"
