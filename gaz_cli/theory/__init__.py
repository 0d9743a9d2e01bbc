"""What theory expects: equations of state, collision rates, speed distributions.

Every formula of ``shared/physics.md`` that ``gaz analyse`` compares a run
with lives here, once. SI units throughout (m, s, kg, K, Pa = N/m^(D-1));
temperatures are in kelvin and enter as k_B*T. Functions accept floats or
NumPy arrays and broadcast; a scalar in gives a float out. Arguments outside
their domain raise :class:`gaz_cli.errors.SceneError` with a one-line message.

Notation: ``dim`` = D in 1..3; ``diameter`` = sigma = 2R; ``number_density``
n = N/V (1/m^D); ``packing_fraction`` eta = n * v_D(sigma/2), i.e. n*sigma
(1D), pi*n*sigma^2/4 (2D), pi*n*sigma^3/6 (3D); Z = P/(n k T).

Modules (every public name is importable from ``gaz_cli.theory``):

* box pressures for non-interacting particles and 1D rods (exact), and the
  hard-sphere wall pressure to first order in the wall and density corrections;
* the exact density of rod centres for the uniform 1D placement (the exam's Q12);
* compressibility factors Z(eta): Tonks (1D), Henderson and Kolafa-Rottner
  (2D), Carnahan-Starling and Kolafa-Labik-Malijevsky (3D), and the
  dispatcher :func:`compressibility_factor`;
* contact value g(sigma), Enskog collision frequency, mean free path;
* Maxwell-Boltzmann speeds, and the flux-weighted statistics of wall hits;
* uniform gravity: barometric profile and floor/ceiling pressures;
* Haff's cooling law for inelastic particles;
* virial pressure of a periodic box, kinetic temperature.
"""

from gaz_cli.constants import K_B  # noqa: F401  (theory.K_B, as before the split)
from gaz_cli.theory.eos import (  # noqa: F401
    KOLAFA_ROTTNER_MAX_PACKING, KLM_MAX_PACKING, MODELS, BEST_MODEL, particle_volume, packing_fraction,
    density_from_packing, z_tonks, z_henderson, z_kolafa_rottner, z_carnahan_starling, z_klm,
    compressibility_factor, hard_sphere_pressure,
    FREEZING_PACKING, MELTING_PACKING, FCC_CLOSE_PACKING, z_fcc_speedy)
from gaz_cli.theory.mixtures import (  # noqa: F401
    mixture_pressure, mixture_contact_values, mixture_pressure_mapped, mixture_contact_values_mapped)
from gaz_cli.theory.walls import (  # noqa: F401
    ideal_gas_pressure, ideal_wall_pressure, ideal_accessible_pressure, tonks_pressure,
    rods_wall_pressure, hard_sphere_wall_pressure, wall_adsorption, wall_adsorption_shift,
    mixture_wall_pressure, rod_centre_density, ring_pressure, bulk_wall_pressure)
from gaz_cli.theory.transport import (  # noqa: F401
    rods_collision_frequency, rods_collision_frequency_exact, contact_value, enskog_collision_frequency,
    pair_collision_density, mean_free_path)
from gaz_cli.theory.speeds import (  # noqa: F401
    speed_pdf, mean_speed, rms_speed, most_probable_speed, wall_hit_speed_pdf, wall_hit_mean_speed,
    fixed_energy_hit_speed_factor, wall_hit_normal_speed_pdf, wall_hit_mean_normal_speed, wall_hit_rate,
    rods_hit_speed_sampling_error)
from gaz_cli.theory.gravity import (  # noqa: F401
    barometric_height_pdf, ideal_gravity_wall_pressures, floor_minus_ceiling_pressure,
    chemical_potential_excess, hard_sphere_gravity_wall_pressures, hard_sphere_gravity_profile,
    gravity_collision_frequency, gravity_energy_temperature)
from gaz_cli.theory.cooling import (  # noqa: F401
    haff_cooling_rate, haff_temperature, haff_temperature_per_collision, haff_collisions_per_particle)
from gaz_cli.theory.mechanics import (  # noqa: F401
    virial_pressure, kinetic_temperature, wall_impulse)

__all__ = [
    "KOLAFA_ROTTNER_MAX_PACKING", "KLM_MAX_PACKING", "MODELS", "BEST_MODEL",
    "particle_volume", "packing_fraction", "density_from_packing",
    "ideal_gas_pressure", "ideal_wall_pressure", "ideal_accessible_pressure",
    "tonks_pressure", "rods_wall_pressure", "hard_sphere_wall_pressure",
    "wall_adsorption", "wall_adsorption_shift",
    "mixture_pressure", "mixture_contact_values", "mixture_wall_pressure",
    "rod_centre_density", "rods_collision_frequency", "rods_collision_frequency_exact",
    "z_tonks", "z_henderson", "z_kolafa_rottner", "z_carnahan_starling", "z_klm",
    "compressibility_factor", "hard_sphere_pressure",
    "contact_value", "enskog_collision_frequency", "pair_collision_density", "mean_free_path",
    "speed_pdf", "mean_speed", "rms_speed", "most_probable_speed",
    "wall_hit_speed_pdf", "wall_hit_mean_speed", "fixed_energy_hit_speed_factor",
    "wall_hit_normal_speed_pdf", "wall_hit_mean_normal_speed", "wall_hit_rate",
    "barometric_height_pdf", "ideal_gravity_wall_pressures", "floor_minus_ceiling_pressure",
    "chemical_potential_excess", "hard_sphere_gravity_wall_pressures", "hard_sphere_gravity_profile",
    "gravity_collision_frequency", "gravity_energy_temperature",
    "haff_cooling_rate", "haff_temperature", "haff_temperature_per_collision",
    "haff_collisions_per_particle", "rods_hit_speed_sampling_error",
    "virial_pressure", "kinetic_temperature", "wall_impulse",
    "ring_pressure", "bulk_wall_pressure", "mixture_pressure_mapped", "mixture_contact_values_mapped", "FREEZING_PACKING", "MELTING_PACKING", "FCC_CLOSE_PACKING", "z_fcc_speedy",
]
