#include "plant/plant_messages.h"
