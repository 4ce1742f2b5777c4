// Implemented with the crankpin work; see pin_grinder.h.
#include "simulator/pin_grinder.h"
