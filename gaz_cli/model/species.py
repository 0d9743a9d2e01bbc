"""The built-in gases: the rows PARTICULE is seeded with.

Masses: molar masses from the CIAAW standard atomic weights (H 1.008, C 12.011,
N 14.007, O 15.999; Ar 39.95), divided by N_A.
Radii: half the hard-sphere diameter d_eta obtained from the gas viscosity at
25 degC and 100 kPa (CRC Handbook of Chemistry and Physics, 100th ed., table
"Mean free path and related properties of gases"; CH4 computed from the CRC
viscosity 11.1 uPa.s), which is the diameter kinetic theory of hard spheres
uses: d^2 = (5/16) sqrt(m k T / pi) / eta_v.
"""

from __future__ import annotations

from dataclasses import dataclass

from gaz_cli.constants import N_A
from gaz_cli.errors import SceneError


NAME_MAX = 64
"""The longest species name, in characters: PARTICULE.PA_NOM is VARCHAR(64) (PostgreSQL
enforces it; SQLite does not)."""

NAME_SEPARATORS = ",:"
"""Characters a species name may not hold: they separate the entries of a mixture ('Ar:500,He:500',
--species and the composition column SPECIES), which a name holding one would make ambiguous."""


def split_list(text: str, what: str, example: str) -> list[str]:
    """The entries of a comma-separated list given on the command line or in a scene file
    (``--species Ar:500,He:500``, ``--vary temperature=100,200``, ``--plane 0,1:0,1``), each
    stripped of spaces: the one rule for every such list. An empty entry -- a comma leading,
    trailing or doubled -- is refused, SceneError naming where (``what``: the option and its
    text, ``example``: a list written right): it is a value lost more often than a
    style (``He:10,$OTHER`` with $OTHER unset), and --vary and --plane refused it while
    --species dropped it."""
    items = [item.strip() for item in text.split(",")]
    if len(items) > 1 and not all(items):
        k = items.index("")
        where = ("before the first comma" if k == 0 else "after the last comma" if k == len(items) - 1
                 else "between two commas")
        raise SceneError(f"{what}: an empty entry {where}; give a value between every two commas, "
                         f"e.g. {example}")
    return items


@dataclass(frozen=True)
class Species:
    """One kind of particle. ``mass`` in kg, ``radius`` in m."""

    name: str
    mass: float
    radius: float

    @property
    def mass_g(self) -> float:
        """Mass in grams, the unit of PARTICULE.PA_M."""
        return self.mass * 1e3


# name, molar mass g/mol, hard-sphere (viscosity) diameter in angstrom
_TABLE = [
    ("He", 4.002602, 2.15),
    ("Ne", 20.1797, 2.54),
    ("Ar", 39.95, 3.58),
    ("Kr", 83.798, 4.08),
    ("Xe", 131.293, 4.78),
    ("H2", 2.016, 2.71),
    ("N2", 28.014, 3.70),
    ("O2", 31.998, 3.55),
    ("CO2", 44.009, 4.53),
    ("CH4", 16.043, 4.08),
]

BUILTIN: dict[str, Species] = {
    name: Species(name, molar * 1e-3 / N_A, diameter_angstrom * 0.5e-10)
    for name, molar, diameter_angstrom in _TABLE
}
"""Built-in species by name, in the order of PARTICULE.PA_NUM (1-based)."""

DEFAULT_SPECIES = "Ar"

_ALIASES = {name.lower(): name for name in BUILTIN}
_ALIASES.update({"argon": "Ar", "helium": "He", "neon": "Ne", "krypton": "Kr",
                 "xenon": "Xe", "hydrogen": "H2", "nitrogen": "N2", "oxygen": "O2",
                 "methane": "CH4"})


def builtin_named(name: str) -> Species | None:
    """The built-in species ``lookup(name)`` gives ('ar' and 'argon' give Ar), or None."""
    key = _ALIASES.get(name.strip().lower())
    return BUILTIN[key] if key is not None else None


def lookup(name: str) -> Species:
    """The built-in species called ``name`` (case-insensitive; 'argon' works too)."""
    key = _ALIASES.get(name.strip().lower())
    if key is None:
        raise SceneError(f"unknown species {name!r}; known: {', '.join(BUILTIN)} "
                         "(or give --radius and --mass)")
    return BUILTIN[key]


def parse_mixture(spec: str, n: int | None) -> list[tuple[Species, int]]:
    """Parse ``--species``: 'Ar' (all n particles) or 'Ar:500,He:500'.

    Returns a list of (species, count). With counts given, ``n`` must be None or
    equal their sum.
    """
    parts = [p for p in split_list(spec, f"--species {spec!r}", "Ar:500,He:500") if p]
    if not parts:
        raise SceneError("--species is empty; give a name such as Ar or a mixture Ar:500,He:500")
    if len(parts) == 1 and ":" not in parts[0]:
        if n is None:
            raise SceneError("--n is required with a single --species")
        return [(lookup(parts[0]), n)]
    out = []
    for part in parts:
        if ":" not in part:
            raise SceneError(f"mixture entry {part!r} lacks a count; write NAME:COUNT, e.g. Ar:500,He:500")
        name, count = part.split(":", 1)
        try:
            k = int(count)
        except ValueError:
            raise SceneError(f"count {count!r} of {name} is not a whole number") from None
        if k <= 0:
            raise SceneError(f"count of {name} is {k}; counts must be positive")
        out.append((lookup(name), k))
    names = [s.name for s, _ in out]
    if len(set(names)) != len(names):
        raise SceneError("a species appears twice in --species; merge the counts")
    total = sum(k for _, k in out)
    if n is not None and n != total:
        raise SceneError(f"--n {n} differs from the mixture total {total}; drop --n or make them agree")
    return out
