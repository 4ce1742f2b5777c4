// The central history's schema as an ordered list of migrations, each applied in one
// transaction and recorded in central_schema_version (docs/plant.md, "The central history").
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "core/result.h"
#include "plant/central_history.h"

namespace gaugeloop {

struct CentralMigration {
  int version = 0;
  std::string_view description;
  std::string_view sql;
};

std::span<const CentralMigration> central_migrations();
int latest_central_schema_version();

namespace central_internal {
struct CentralConnection;

// The version the database holds: 0 without a central history (no central_schema_version).
Result<int> read_central_version(CentralConnection& c);

// Brings the schema up to date, one migration per transaction under an advisory lock, so two
// grinders syncing at once migrate once. kStorage for a newer schema (nothing written).
Status migrate(CentralConnection& c);

// kStorage unless the schema is exactly the latest: none (sync first), older (sync upgrades),
// newer (a newer gaugeloop wrote it).
Status require_latest(CentralConnection& c);
}  // namespace central_internal

}  // namespace gaugeloop
