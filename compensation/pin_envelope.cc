// Implemented with the crankpin work; see pin_envelope.h.
#include "compensation/pin_envelope.h"
