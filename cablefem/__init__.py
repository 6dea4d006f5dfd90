"""cablefem: bending moments at the anchors of vibrating cables.

The extensible string (outer solution) is solved with FEniCSx; the closed-form inner
solution of a matched asymptotic expansion gives the bending moment in the boundary layer at
every clamped anchor (see the README and ``docs/theory.md``).
"""

__version__ = "0.1.0"
