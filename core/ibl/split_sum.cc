#include "core/ibl/split_sum.h"
