"""Physical constants (SI, CODATA 2018) used across the package."""

SPEED_OF_LIGHT = 299_792_458.0  # m/s
STEFAN_BOLTZMANN = 5.670374419e-8  # W m^-2 K^-4
LIGHT_YEAR = 9.4607304725808e15  # m (Julian year)
#: Mass of a hydrogen atom [kg]: the lightest particle a sail can sweep up.
HYDROGEN_MASS_KG = 1.6735575e-27
