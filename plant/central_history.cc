#include "plant/central_history.h"
