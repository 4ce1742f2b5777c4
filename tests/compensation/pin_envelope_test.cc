// Crankpin tests; filled in with the crankpin work.
#include <gtest/gtest.h>
