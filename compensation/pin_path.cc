// Implemented with the crankpin work; see pin_path.h.
#include "compensation/pin_path.h"
