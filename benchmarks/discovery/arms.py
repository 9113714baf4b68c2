"""Which record of a laws batch's case is the loop with discovery as the package stands, for the results page and
the guide's figure: the latest arm that ran on the case, of the arms each of which revised the one after it (a fix
that does not apply to a case was not run on it, and the arm before it stands there)."""

PACKAGE_NOW = ("loop_discovery_fluxes", "loop_discovery_powered", "loop_discovery_angle_difference",
               "loop_discovery_no_phase", "loop_discovery_parts", "loop_discovery_modulated", "loop_discovery_phases",
               "loop_discovery_in_range", "loop_discovery_canonical", "loop_discovery_limited",
               "loop_discovery_inhibited", "loop_discovery_learned", "loop_discovery_folded", "loop_discovery_finite",
               "loop_discovery_judged")
PACKAGE_NOW_LABEL = ("closed loop + discovery as the package stands (the latest of 'a flux's factor screened on "
                     "all its equations', 'a science term scaled by a power of a variable of one sign', 'the "
                     "plain difference of two angles beside its harmonic', 'a difference of two phases tried without "
                     "its phase', "
                     "'the search only where the network's part on the equation counts', 'a science term scaled by "
                     "exp(k x)', 'the harmonic of a difference of two angles', 'a limited reading only with "
                     "its K among the visited states', 'an inhibited term written "
                     "slowed down unless limited is the law', 'the science's terms slowed down or limited by a "
                     "variable', 'the science's terms slowed down by a variable', 'a parameter-free "
                     "equation the network learned kept', 'a number's function evaluated', 'no gate on a diverged "
                     "trajectory' and 'every form judged' that ran)")


def package_now(record: dict) -> dict | None:
    """The record's arm of the package as it stands, or None where none of them ran."""
    return next((record[arm] for arm in PACKAGE_NOW if arm in record), None)
