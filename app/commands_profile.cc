// profile: the wheel path of a part, printed for inspection.
#include "app/cli_common.h"

namespace gaugeloop {

void add_profile_commands(CLI::App& /*app*/, CommandAction& /*action*/) {}

}  // namespace gaugeloop
