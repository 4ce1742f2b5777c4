// The plant's central history in PostgreSQL (docs/plant.md, "The central history"): every
// grinder's runs, pushes and events, replicated from its local file by UUID
// (plant/central_sync.h), and queried across machines with the same answers the local file
// gives (RunHistory).
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// A postgresql:// URL as gaugeloop uses it: libpq's URL form,
//   postgresql://[USER[:PASSWORD]@][HOST][:PORT]/DATABASE[?KEY=VALUE&...]
// ("postgres://" too). The database is required; host empty: the local socket; port empty: 5432.
struct CentralUrl {
  std::string url;            // as given, for libpq (plus connect_timeout=10 unless given)
  std::string shown;          // as given with the password replaced by "***": for messages and output
  bool has_password = false;  // the URL holds a password (USER:PASSWORD@ or ?password=)
  std::string host;           // "" for the local socket
  std::string port;           // "5432" unless given
  std::string database;
};

// kInvalidInput naming the part of the URL that is wrong (scheme, port, database...) and the
// form to write, e.g. "postgresql://gaugeloop@central:5432/plant".
Result<CentralUrl> parse_central_url(std::string_view url);

namespace central_internal {
struct CentralConnection;
}  // namespace central_internal

// The central history, read. One connection, opened by open(); the queries answer as
// RunStore's do for the same RunQuery: the same filters, the same rows (summary.id is the run's
// id in its grinder's file), the same order (newest first by started_utc, then id; runs of two
// grinders that tie on both come by machine synced from, then UUID), the same messages for a
// bad query. Thread: one CentralHistory per thread.
class CentralHistory : public RunHistory {
 public:
  // Connects and checks the schema: kInvalidInput for a URL it cannot use, kStorage for a server
  // it cannot reach, a database without a central history (run `gaugeloop plant sync` first),
  // an older schema (`plant sync` upgrades it) or a newer one (a newer gaugeloop wrote it).
  static Result<CentralHistory> open(const std::string& url);

  CentralHistory(CentralHistory&&) noexcept;
  CentralHistory& operator=(CentralHistory&&) noexcept;
  ~CentralHistory() override;

  Result<std::vector<RunSummary>> list_runs(const RunQuery& q) const override;
  Result<std::vector<RunSummary>> trend(const RunQuery& q) const override;
  using RunHistory::characteristics;
  Result<std::vector<RunCharacteristics>> characteristics(const RunQuery& q, const std::string& key) const override;
  Result<CharacteristicSummaries> characteristic_summaries(const RunQuery& q) const override;

  const CentralUrl& url() const;

 private:
  explicit CentralHistory(std::unique_ptr<central_internal::CentralConnection> conn);
  std::unique_ptr<central_internal::CentralConnection> conn_;
};

}  // namespace gaugeloop
