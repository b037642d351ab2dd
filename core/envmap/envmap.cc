#include "core/envmap/envmap.h"
