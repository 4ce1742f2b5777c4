// The main program: rendered from the shipped template with every placeholder filled, refused
// when it would couple another table than the one its subprogram defines; and the table
// numbers alternating with the version.
#include "nc_out/main_program.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "nc_out/table_layer.h"
#include "nc_out/table_program.h"
#include "tests/nc_out/analytic_path.h"

#include "infeed_values.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

std::string shipped_main_template() {
  std::ifstream in(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/cam_main.mpf");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::map<std::string, std::string> main_values(const std::string& table_number) {
  std::map<std::string, std::string> v{{"program_name", "CAM_INTAKE_L1"},
                                       {"part", "intake_flat"},
                                       {"lobe", "1"},
                                       {"version", "0.1.0"},
                                       {"run_id", "42"},
                                       {"origin", "run 42"},
                                       {"created_utc", "2026-12-01T10:00:00Z"},
                                       {"table_version", "3"},
                                       {"table_number", table_number},
                                       {"table_start_c_deg", "180.000"},
                                       {"point_count", "91"},
                                       {"interpolation", "cspline"}};
  testing::add_infeed_values(v);
  return v;
}

TEST(MainProgram, TheShippedTemplateFillsEveryPlaceholderAndCouplesTheTableNamed) {
  Result<std::string> r = render_main_program(shipped_main_template(), "cam_main.mpf", main_values("2"));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->find("{{"), std::string::npos) << *r;
  EXPECT_THAT(*r, HasSubstr("N10 CAM_INTAKE_L1 "));
  EXPECT_THAT(*r, HasSubstr("EGON(X,\"FINE\",C,2,0)"));
  EXPECT_THAT(*r, HasSubstr("table version 3 of run 42"));
  Result<int> coupled = coupled_table_number(*r, "CAM_INTAKE_L1_MAIN.MPF");
  ASSERT_TRUE(coupled.ok()) << coupled.error().message;
  EXPECT_EQ(*coupled, 2);
}

TEST(MainProgram, AnUnknownPlaceholderIsRefusedNamingItAndTheTemplate) {
  const std::string text = shipped_main_template() + "; {{tabel_number}}\n";
  Result<std::string> r = render_main_program(text, "/etc/gaugeloop/cam_main.mpf", main_values("1"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(r.error().message, HasSubstr("tabel_number"));
  EXPECT_THAT(r.error().message, HasSubstr("/etc/gaugeloop/cam_main.mpf"));
}

TEST(MainProgram, ATemplateCouplingAFixedTableIsRefused) {
  const std::string text = "N10 {{program_name}}\nN20 EGON(X,\"FINE\",C,1,0)\nM30\n";
  Result<std::string> r = render_main_program(text, "fixed.mpf", main_values("2"));
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("couples curve table 1 at line 2, not table 2"));
  EXPECT_TRUE(render_main_program(text, "fixed.mpf", main_values("1")).ok());
}

TEST(MainProgram, ATemplateThatDoesNotCallTheTableOrCouplesNothingIsRefused) {
  Result<std::string> no_call =
      render_main_program("N20 EGON(X,\"FINE\",C,{{table_number}},0)\nM30\n", "a.mpf", main_values("1"));
  ASSERT_FALSE(no_call.ok());
  EXPECT_THAT(no_call.error().message, HasSubstr("does not call the table subprogram CAM_INTAKE_L1"));
  Result<std::string> no_coupling = render_main_program("N10 {{program_name}}\nM30\n", "b.mpf", main_values("1"));
  ASSERT_FALSE(no_coupling.ok());
  EXPECT_THAT(no_coupling.error().message, HasSubstr("couples no curve table"));
}

// A table subprogram run from a drive (execution from external source) is a call too; another
// program's name in EXTCALL is not.
TEST(MainProgram, AnExtcallOfTheTableSubprogramCallsIt) {
  const std::string couple = "N20 EGON(X,\"FINE\",C,{{table_number}},0)\nM30\n";
  EXPECT_TRUE(render_main_program("N10 EXTCALL(\"{{program_name}}\")\n" + couple, "a.mpf", main_values("1")).ok());
  Result<std::string> other = render_main_program("N10 EXTCALL(\"OTHER\")\n" + couple, "b.mpf", main_values("1"));
  ASSERT_FALSE(other.ok());
  EXPECT_THAT(other.error().message, HasSubstr("does not call the table subprogram CAM_INTAKE_L1"));
}

TEST(TableNumbers, ConsecutiveVersionsAlternateAndTheHeaderNamesTheNumber) {
  Result<CurveTable> t = write_linear_table(testing::analytic_path(4.0, 0.7), 2.0);
  ASSERT_TRUE(t.ok());
  const std::string tmpl = "{{table_header}}\nCTABDEF(X,C,{{table_number}},1)\n{{table_blocks}}\nCTABEND\nM17\n";
  const int expected[] = {0, 7, 12, 7, 12};
  for (int version = 1; version <= 4; ++version) {
    EXPECT_EQ(table_number_for_version({7, 12}, version), expected[version]);
    Result<std::string> p = render_table_program(tmpl, "t.spf", {}, *t, {5, version, {7, 12}});
    ASSERT_TRUE(p.ok()) << p.error().message;
    Result<ParsedTable> back = parse_table_program(*p, "t.spf");
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->table_number, expected[version]) << "version " << version;
    EXPECT_EQ(back->header["table_number"], std::to_string(expected[version]));
    EXPECT_EQ(back->header["table_numbers"], "7 12");
  }
  EXPECT_EQ(table_number_for_version({7, 12}, 0), 7) << "a pending table, its version not yet known";
}

TEST(TableNumbers, ATableTemplateWithAFixedNumberIsRefusedWhenTheTablesAlternate) {
  Result<CurveTable> t = write_linear_table(testing::analytic_path(4.0, 0.7), 2.0);
  ASSERT_TRUE(t.ok());
  const std::string tmpl = "{{table_header}}\nCTABDEF(X,C,1,1)\n{{table_blocks}}\nCTABEND\nM17\n";
  EXPECT_TRUE(render_table_program(tmpl, "fixed.spf", {}, *t, {5, 1, {1, 2}}).ok());
  Result<std::string> second = render_table_program(tmpl, "fixed.spf", {}, *t, {5, 2, {1, 2}});
  ASSERT_FALSE(second.ok());
  EXPECT_THAT(second.error().message, HasSubstr("CTABDEF names table 1, not table 2"));
}

// A correction layer (docs/nc_output.md): the design table from C and the layer from SIM1,
// SIM1 following C 1:1.
std::map<std::string, std::string> layer_values() {
  std::map<std::string, std::string> v = main_values("2");
  v["design_program_name"] = "CAM_INTAKE_L1_DESIGN";
  v["design_table_number"] = "5";
  v["leading_axis"] = "SIM1";
  return v;
}

std::string shipped_layer_template() {
  std::ifstream in(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/cam_main_layer.mpf");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(MainProgramLayer, TheShippedTemplateCouplesTheDesignFromCAndTheLayerFromSim1) {
  Result<std::string> r = render_main_program(shipped_layer_template(), "cam_main_layer.mpf", layer_values());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->find("{{"), std::string::npos) << *r;
  EXPECT_THAT(*r, HasSubstr("N10 CAM_INTAKE_L1_DESIGN "));
  EXPECT_THAT(*r, HasSubstr("EGON(X,\"FINE\",C,5,0,SIM1,2,0)"));
  EXPECT_THAT(*r, HasSubstr("EGON(SIM1,\"FINE\",C,1,1)"));
  // The number a push and a reconciliation compare with the table on the control: the layer's.
  Result<int> coupled = coupled_table_number(*r, "CAM_INTAKE_L1_MAIN.MPF");
  ASSERT_TRUE(coupled.ok()) << coupled.error().message;
  EXPECT_EQ(*coupled, 2);
  Result<int> x = coupled_table_number(*r, "CAM_INTAKE_L1_MAIN.MPF", "X");
  ASSERT_TRUE(x.ok());
  EXPECT_EQ(*x, 2);
}

TEST(MainProgramLayer, ATemplateThatWouldGrindWithoutTheLayerOrOffAngleIsRefused) {
  const std::string good = shipped_layer_template();
  struct Case {
    std::string from;
    std::string to;
    std::string says;
  };
  const std::vector<Case> cases = {
      // X from the design alone: the correction would never reach the wheel.
      {"EGON(X,\"FINE\",C,{{design_table_number}},0,SIM1,{{table_number}},0)",
       "EGON(X,\"FINE\",C,{{design_table_number}},0)", "without the correction"},
      // The layer alone: the design would be missing.
      {"EGON(X,\"FINE\",C,{{design_table_number}},0,SIM1,{{table_number}},0)",
       "EGON(X,\"FINE\",SIM1,{{table_number}},0)", "the correction alone"},
      // SIM1 geared 2:1 to C: the layer read at another angle.
      {"EGON(SIM1,\"FINE\",C,1,1)", "EGON(SIM1,\"FINE\",C,2,1)", "otherwise than to C 1:1"},
      // The design table's subprogram not called: table 5 undefined on the control.
      {"N10 {{design_program_name}}", "N10", "does not call the design table's subprogram CAM_INTAKE_L1_DESIGN"},
      // A fixed table number for the layer.
      {"SIM1,{{table_number}},0)", "SIM1,1,0)", "otherwise than through the design table 5"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.to);
    std::string text = good;
    const std::size_t at = text.find(c.from);
    ASSERT_NE(at, std::string::npos);
    text.replace(at, c.from.size(), c.to);
    Result<std::string> r = render_main_program(text, "mine.mpf", layer_values());
    ASSERT_FALSE(r.ok());
    EXPECT_THAT(r.error().message, HasSubstr("mine.mpf"));
    EXPECT_THAT(r.error().message, HasSubstr(c.says));
  }
  std::map<std::string, std::string> same = layer_values();
  same["design_table_number"] = "2";
  Result<std::string> r = render_main_program(good, "cam_main_layer.mpf", same);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("same curve table 2"));
}

TEST(TableLayer, ALayerIsWrittenFromSim1AndATemplateNamingCIsRefused) {
  Result<CurveTable> t = write_linear_table(testing::analytic_path(0.01, 0.7), 2.0);
  ASSERT_TRUE(t.ok());
  TableProvenance layer{5, 3, {1, 2}};
  layer.design_program = "CAM_DESIGN";
  layer.design_table_number = 7;
  const std::string tmpl =
      "{{table_header}}\nCTABDEF(X,{{leading_axis}},{{table_number}},1)\n{{table_blocks}}\nCTABEND\nM17\n";
  Result<std::string> p = render_table_program(tmpl, "layer.spf", {}, *t, layer);
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_THAT(*p, HasSubstr("CTABDEF(X,SIM1,1,1)"));
  EXPECT_THAT(*p, HasSubstr("G1 SIM1=0.000 X"));
  Result<ParsedTable> back = parse_table_program(*p, "layer.spf");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->points.size(), t->points.size());
  Result<LayerOf> of = layer_of(*back, "layer.spf");
  ASSERT_TRUE(of.ok());
  EXPECT_EQ(of->design_program, "CAM_DESIGN");
  EXPECT_EQ(of->design_table_number, 7);
  // A template that names C would make the layer a second table on C: refused.
  const std::string on_c = "{{table_header}}\nCTABDEF(X,C,{{table_number}},1)\n{{table_blocks}}\nCTABEND\nM17\n";
  Result<std::string> refused = render_table_program(on_c, "mine.spf", {}, *t, layer);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error().message, HasSubstr("mine.spf"));
}

TEST(TableLayer, TheDesignTableIsReadOnlyAsTheTableNumberedAndUneditedFromC) {
  Result<CurveTable> t = write_linear_table(testing::analytic_path(4.0, 0.7), 2.0);
  ASSERT_TRUE(t.ok());
  const std::string tmpl = "{{table_header}}\nCTABDEF(X,C,{{table_number}},1)\n{{table_blocks}}\nCTABEND\nM17\n";
  Result<std::string> design = render_table_program(tmpl, "D.SPF", {}, *t, {0, 0, {5, 5}});
  ASSERT_TRUE(design.ok()) << design.error().message;
  Result<DesignTable> read = read_design_table(*design, "D.SPF", 5);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_NEAR(read->nc.at(2.0).x_mm, t->points[1].x_mm, 1e-12);
  Result<DesignTable> other = read_design_table(*design, "D.SPF", 6);
  ASSERT_FALSE(other.ok());
  EXPECT_THAT(other.error().message, HasSubstr("defines table 5, not the design table 6"));
  std::string edited = *design;
  const std::size_t at = edited.find("C2.000 X");
  ASSERT_NE(at, std::string::npos);
  edited[at + 11] = edited[at + 11] == '9' ? '8' : '9';
  Result<DesignTable> hand = read_design_table(edited, "D.SPF", 5);
  ASSERT_FALSE(hand.ok());
  EXPECT_THAT(hand.error().message, HasSubstr("nc new --replace"));
}

}  // namespace
}  // namespace gaugeloop
