// Implemented with the crankpin work; see pin_analysis.h.
#include "compensation/pin_analysis.h"
