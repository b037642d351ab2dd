#include "core/export/ktx2.h"
