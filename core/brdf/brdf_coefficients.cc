#include "core/brdf/brdf_coefficients.h"
