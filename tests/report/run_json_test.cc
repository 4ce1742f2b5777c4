// The run history as JSON: a run stored in a real database and read back, every key the HTTP
// API documents present, figures named with their unit, null where nothing was recorded.
#include "report/run_json.h"

#include <gtest/gtest.h>

#include "core/uuid.h"

#include <set>
#include <string>

#include "storage/run_store.h"
#include "tests/report/stored_run_test.h"
#include "tests/support/sample_runs.h"

namespace gaugeloop {
namespace {

using nlohmann::json;

// docs/http_api.md, GET /api/runs: one row of the run list.
const std::set<std::string> kSummaryKeys = {"id",
                                            "uuid",
                                            "started_utc",
                                            "machine",
                                            "part",
                                            "lobe",
                                            "status",
                                            "revolutions",
                                            "degrees_captured",
                                            "max_abs_error_um",
                                            "rms_error_um",
                                            "peak_to_valley_um",
                                            "repeatability_um",
                                            "phase_error_deg",
                                            "base_circle_runout_um",
                                            "settings_hash",
                                            "serial",
                                            "operator",
                                            "verdict",
                                            "note",
                                            "nc_file",
                                            "raw_pruned_utc"};

// docs/http_api.md, GET /api/runs/{id}: the summary's keys plus these.
const std::set<std::string> kDetailKeys = {"part_temperature_c",
                                           "part_temperature_source",
                                           "lift_error_reference",
                                           "judged_error",
                                           "harmonics_fed_back",
                                           "harmonic_threshold_um",
                                           "max_abs_residual_um",
                                           "rms_residual_um",
                                           "peak_to_valley_residual_um",
                                           "dial_runout_um",
                                           "roundness_um",
                                           "characteristics",
                                           "finished_utc",
                                           "gauge",
                                           "polls",
                                           "reconnects",
                                           "discarded_revolutions",
                                           "zero_offset_mm",
                                           "max_abs_error_at_cam_deg",
                                           "correction_max_um",
                                           "correction_in_force_run",
                                           "ground_with_version",
                                           "ground_with_source",
                                           "inspection",
                                           "harmonic_amplitude_um",
                                           "settings",
                                           "frame",
                                           "nc_pushes",
                                           "part_kind"};

// docs/http_api.md, GET /api/nc/history: one push.
const std::set<std::string> kPushKeys = {"nc_file",     "table_version",     "pushed_utc",   "run_id",
                                         "reason",      "interpolation",     "block_count",  "command_error_um",
                                         "point_count", "correction_max_um", "program_hash", "uuid"};

std::set<std::string> keys_of(const json& object) {
  std::set<std::string> keys;
  for (const auto& [key, value] : object.items()) keys.insert(key);
  return keys;
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// A measured figure (a floating-point value) is named with its unit: _um, _mm or _deg. Objects
// and arrays are walked; an array takes its key's name.
void expect_units_in_names(const json& j, const std::string& key = "") {
  if (j.is_object()) {
    for (const auto& [k, v] : j.items()) expect_units_in_names(v, k);
  } else if (j.is_array()) {
    for (const json& v : j) expect_units_in_names(v, key);
  } else if (j.is_number_float()) {
    EXPECT_TRUE(ends_with(key, "_um") || ends_with(key, "_mm") || ends_with(key, "_deg") || ends_with(key, "_c"))
        << "`" << key << "` holds a figure but names no unit";
  } else if (j.is_string() && j.get<std::string>().size() == 20 && j.get<std::string>()[10] == 'T') {
    EXPECT_TRUE(ends_with(key, "_utc")) << "`" << key << "` holds a time but is not named _utc";
  }
}

using RunJsonTest = testing::StoredRunTest;

TEST_F(RunJsonTest, AStoredRunHasEveryDocumentedKeyAndItsFigures) {
  RunRecord record = testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:34:44Z", 5.0);
  record.note = "first";
  record.ground_with_version = 1;
  record.ground_with_source = "plc";
  record.settings += "part.temperature_c = 21.4\npart.temperature_source = plc\n";
  const std::int64_t first = insert(testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T01:00:00Z", 6.0));
  record.correction_in_force_run = first;
  const std::int64_t id = insert(record);
  NcPush push;
  push.nc_file = "/nc/CAM_INTAKE_L1.SPF";
  push.table.interpolation = "CSPLINE";
  push.table.block_count = 72;
  push.table.command_error_um = 0.31;
  push.table.point_count = 73;
  push.table.correction_max_um = 4.5;
  push.program_hash = settings_hash("program");
  ASSERT_TRUE(store_->record_push(id, push, "program").ok());

  const json j = run_detail_json(load(id));
  std::set<std::string> expected = kSummaryKeys;
  expected.insert(kDetailKeys.begin(), kDetailKeys.end());
  EXPECT_EQ(keys_of(j), expected);
  expect_units_in_names(j);

  EXPECT_EQ(j["id"], id);
  EXPECT_TRUE(is_uuid(j["uuid"].get<std::string>())) << j["uuid"];
  EXPECT_EQ(j["started_utc"], "2026-11-22T02:34:44Z");
  EXPECT_EQ(j["part"], "intake_flat");
  EXPECT_EQ(j["status"], "pushed");
  EXPECT_EQ(j["revolutions"], 3);
  EXPECT_EQ(j["degrees_captured"], 3 * 360);
  EXPECT_NEAR(j["max_abs_error_um"].get<double>(), 5.0, 1e-9);
  EXPECT_NEAR(j["phase_error_deg"].get<double>(), 0.25, 1e-9);
  EXPECT_NEAR(j["base_circle_runout_um"].get<double>(), 1.5, 1e-9);
  EXPECT_EQ(j["settings_hash"], settings_hash(record.settings));
  EXPECT_EQ(j["settings"], record.settings);
  EXPECT_EQ(j["note"], "first");
  EXPECT_EQ(j["nc_file"], "/nc/CAM_INTAKE_L1.SPF");
  EXPECT_TRUE(j["raw_pruned_utc"].is_null());
  EXPECT_EQ(j["max_abs_error_at_cam_deg"], 90) << "the sample's error is 5 sin(cam degree)";
  EXPECT_NEAR(j["correction_max_um"].get<double>(), 4.5, 1e-3);
  EXPECT_EQ(j["correction_in_force_run"], first);
  EXPECT_EQ(j["ground_with_version"], 1);
  EXPECT_EQ(j["ground_with_source"], "plc");
  EXPECT_EQ(j["part_temperature_c"], 21.4);
  EXPECT_EQ(j["part_temperature_source"], "plc");
  EXPECT_EQ(j["inspection"], false);
  ASSERT_TRUE(j["harmonic_amplitude_um"].is_array());
  EXPECT_EQ(j["harmonic_amplitude_um"].size(), 31u);
  ASSERT_TRUE(j["frame"].is_object());
  EXPECT_EQ(keys_of(j["frame"]), (std::set<std::string>{"rotation_sense", "c_offset_deg", "probe_offset_deg"}));
  EXPECT_EQ(j["frame"]["c_offset_deg"], 10.0);
  // The sample keeps no best-fit table: its judged curve is the raw error, and says so.
  EXPECT_EQ(keys_of(j["judged_error"]), (std::set<std::string>{"name", "reference", "max_abs_um", "max_abs_at_deg",
                                                               "rms_um", "peak_to_valley_um"}));
  EXPECT_EQ(j["judged_error"]["reference"], "at nominal timing");
  EXPECT_NEAR(j["judged_error"]["max_abs_um"].get<double>(), 5.0, 1e-3);
  EXPECT_EQ(j["judged_error"]["max_abs_at_deg"], 90);

  ASSERT_EQ(j["nc_pushes"].size(), 1u);
  const json& p = j["nc_pushes"][0];
  EXPECT_EQ(keys_of(p), kPushKeys);
  EXPECT_EQ(p["table_version"], 1);
  EXPECT_TRUE(is_uuid(p["uuid"].get<std::string>())) << p["uuid"];
  EXPECT_NE(p["uuid"], j["uuid"]) << "a push is not its run";
  EXPECT_EQ(p["run_id"], id);
  EXPECT_EQ(p["reason"], "run " + std::to_string(id));
  EXPECT_EQ(p["interpolation"], "CSPLINE");
  EXPECT_EQ(p["block_count"], 72);
  EXPECT_EQ(p["point_count"], 73);
  EXPECT_NEAR(p["command_error_um"].get<double>(), 0.31, 1e-12);

  // The list row is the summary alone.
  auto list = store_->list_runs(RunQuery{});
  ASSERT_TRUE(list.ok()) << list.error().message;
  ASSERT_EQ(list->size(), 2u);
  const json row = run_summary_json(list->front());
  EXPECT_EQ(keys_of(row), kSummaryKeys);
  expect_units_in_names(row);
}

TEST_F(RunJsonTest, APinRunSaysPinItsModeAndTitlesItsRoundnessAsThePins) {
  const std::int64_t cx = insert(testing::sample_pin_run("crankpin_cx", "c-x", "2026-11-22T02:34:44Z", 2.0));
  const std::int64_t cxy = insert(testing::sample_pin_run("crankpin_cxy", "c-x-y", "2026-11-22T02:35:44Z", 2.0));
  RunRecord lobe = testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:36:44Z", 5.0);
  lobe.characteristics = {single_characteristic("roundness", "um", 1.0, Limits{std::nullopt, 4.0})};
  const std::int64_t lobe_id = insert(lobe);

  const json j = run_detail_json(load(cx));
  std::set<std::string> expected = kSummaryKeys;
  expected.insert(kDetailKeys.begin(), kDetailKeys.end());
  expected.insert("pin_mode");
  EXPECT_EQ(keys_of(j), expected);
  EXPECT_EQ(j["part_kind"], "pin");
  EXPECT_EQ(j["pin_mode"], "c-x");
  ASSERT_EQ(j["characteristics"].size(), 4u);
  EXPECT_EQ(j["characteristics"][0]["key"], "roundness");
  EXPECT_EQ(j["characteristics"][0]["title"], "Pin roundness");
  EXPECT_EQ(j["characteristics"][1]["title"], "Pin diameter error");
  EXPECT_EQ(j["characteristics"][0]["judges"], "less LS circle") << "roundness is of the curve less the circle";
  EXPECT_TRUE(j["characteristics"][1]["judges"].is_null()) << "the diameter is a figure of its own";
  EXPECT_EQ(j["judged_error"]["reference"], "less LS circle");
  EXPECT_EQ(run_detail_json(load(cxy))["pin_mode"], "c-x-y");

  const json l = run_detail_json(load(lobe_id));
  EXPECT_EQ(l["part_kind"], "lobe");
  EXPECT_FALSE(l.contains("pin_mode"));
  EXPECT_EQ(l["characteristics"][0]["title"], "Base circle roundness");
}

TEST_F(RunJsonTest, ARunIsAPinOnlyWhenItsSettingsSaySo) {
  RunRecord unknown_mode = testing::sample_pin_run("crankpin", "c-x-z", "2026-11-22T02:34:44Z", 2.0);
  RunRecord mode_alone = testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:35:44Z", 5.0);
  mode_alone.settings = "pin.mode = c-x\n";
  RunRecord bare = testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:36:44Z", 5.0);
  bare.settings.clear();
  const RunPart a = run_part(load(insert(unknown_mode)));
  EXPECT_TRUE(a.pin());
  EXPECT_FALSE(a.pin_mode.has_value());
  const RunPart b = run_part(load(insert(mode_alone)));
  EXPECT_FALSE(b.pin());
  EXPECT_FALSE(b.pin_mode.has_value());
  EXPECT_FALSE(run_part(load(insert(bare))).pin());
}

TEST_F(RunJsonTest, WhatARunDidNotRecordIsNull) {
  RunRecord record = testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-22T02:34:44Z", 5.0);
  record.settings.clear();
  record.geometry.reset();
  const std::int64_t id = insert(record);
  ASSERT_TRUE(store_->record_nc_file(id, "/nc/CAM_INTAKE_L1.SPF").ok());

  const json j = run_detail_json(load(id));
  for (const char* key : {"settings_hash", "settings", "frame", "correction_in_force_run", "ground_with_version",
                          "ground_with_source", "raw_pruned_utc", "serial", "operator"}) {
    EXPECT_TRUE(j[key].is_null()) << key << " = " << j[key];
  }
  ASSERT_EQ(j["nc_pushes"].size(), 1u);
  const json& p = j["nc_pushes"][0];
  for (const char* key : {"block_count", "command_error_um", "point_count", "correction_max_um"}) {
    EXPECT_TRUE(p[key].is_null()) << key << " = " << p[key];
  }

  // A run stored before the inspection figures existed: phase, runout and harmonics null.
  StoredRun old = load(id);
  old.summary.phase_error_deg.reset();
  old.summary.base_circle_runout_um.reset();
  const json o = run_detail_json(old);
  EXPECT_TRUE(o["phase_error_deg"].is_null());
  EXPECT_TRUE(o["base_circle_runout_um"].is_null());
  EXPECT_TRUE(o["harmonic_amplitude_um"].is_null());
}

TEST_F(RunJsonTest, AnEventNotAboutALobeOrRunHasNulls) {
  EventRecord e = testing::sample_refusal_event();
  e.lobe = 0;
  ASSERT_TRUE(store_->record_event(e).ok());
  auto events = store_->list_events(EventQuery{});
  ASSERT_TRUE(events.ok()) << events.error().message;
  ASSERT_EQ(events->size(), 1u);
  const json j = event_json(events->front());
  EXPECT_EQ(keys_of(j), (std::set<std::string>{"id", "uuid", "at_utc", "kind", "code", "machine", "part", "lobe",
                                               "run_id", "message"}));
  EXPECT_TRUE(is_uuid(j["uuid"].get<std::string>())) << j["uuid"];
  EXPECT_EQ(j["kind"], "refusal");
  EXPECT_TRUE(j["lobe"].is_null());
  EXPECT_TRUE(j["run_id"].is_null());
  expect_units_in_names(j);
}

TEST(PendingTableJson, AGearsStrokeNamesItsGearRunAndATableItsRun) {
  PendingTable table;
  table.id = 4;
  table.run_id = 12;
  table.nc_file = "/nc/CAM.SPF";
  const nlohmann::json lobe = pending_table_json(table);
  EXPECT_EQ(lobe["run_id"], 12);
  EXPECT_TRUE(lobe["gear_run_id"].is_null());
  PendingTable stroke;
  stroke.id = 5;
  stroke.gear_run_id = 3;
  stroke.nc_file = "/nc/GEAR_71.SPF";
  const nlohmann::json gear = pending_table_json(stroke);
  EXPECT_EQ(gear["gear_run_id"], 3);
  EXPECT_EQ(gear["run_id"], 0);
}

TEST(TimeBound, AnUntilBoundCoversItsWholeUnit) {
  EXPECT_EQ(*time_bound("2026-11-22", false, "--since"), "2026-11-22T00:00:00Z");
  EXPECT_EQ(*time_bound("2026-11-22", true, "--until"), "2026-11-23T00:00:00Z");
  EXPECT_EQ(*time_bound("2026-11-22 08:30", true, "--until"), "2026-11-22T08:31:00Z");
  EXPECT_EQ(*time_bound("2026-12-31T23:59:59Z", true, "--until"), "2027-01-01T00:00:00Z");
  EXPECT_EQ(*time_bound("", true, "--until"), "");
}

TEST(TimeBound, RefusesWhatIsNotADateNamingTheOption) {
  auto bad = time_bound("22/11/2026", false, "--since");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(bad.error().message.rfind("--since '22/11/2026' is not a UTC date or time; write 2026-11-22", 0), 0u)
      << bad.error().message;
  auto unreal = time_bound("2026-02-30", true, "until");
  ASSERT_FALSE(unreal.ok());
  EXPECT_EQ(unreal.error().message, "until '2026-02-30' is not a real date or time");
}

}  // namespace
}  // namespace gaugeloop
