// The slides' compensation files: the control's syntax and signs, read back, and refused when
// edited by hand or when they hold what gaugeloop does not write.
#include "nc_out/slide_compensation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

std::vector<SlideCompensationTable> two_tables() {
  SlideCompensationTable lec;
  lec.kind = SlideTableKind::kLeadscrew;
  lec.input_axis = lec.output_axis = 'Z';
  lec.min_mm = -4.0;
  lec.step_mm = 2.0;
  lec.error_mm = {0.0012, 0.0, -0.0031, 0.00049, 0.0};
  SlideCompensationTable cec;
  cec.kind = SlideTableKind::kInterpolatory;
  cec.input_axis = 'Z';
  cec.output_axis = 'Y';
  cec.min_mm = -2.0;
  cec.step_mm = 2.0;
  cec.error_mm = {-0.002, 0.0, 0.002};
  return {lec, cec};
}

TEST(SlideCompensation, TheFilesSayWhatTheManualSaysWithItsSigns) {
  Result<std::string> lec = render_slide_compensation(SlideTableKind::kLeadscrew, two_tables(), {});
  ASSERT_TRUE(lec.ok()) << lec.error().message;
  EXPECT_EQ(lec->rfind("%_N_AX_EEC_INI\n", 0), 0u);
  // An LEC value moves the axis against its sign: the error itself.
  EXPECT_THAT(*lec, HasSubstr("CHANDATA(1)\n$AA_ENC_COMP[0,0,Z1]=0.0012\n$AA_ENC_COMP[0,1,Z1]=0.0000\n"
                              "$AA_ENC_COMP[0,2,Z1]=-0.0031\n$AA_ENC_COMP[0,3,Z1]=0.0005\n"));
  EXPECT_THAT(*lec, HasSubstr("$AA_ENC_COMP_STEP[0,Z1]=2.0000\n$AA_ENC_COMP_MIN[0,Z1]=-4.0000\n"
                              "$AA_ENC_COMP_MAX[0,Z1]=4.0000\n$AA_ENC_COMP_IS_MODULO[0,Z1]=0\nM17\n"));
  Result<std::string> cec = render_slide_compensation(SlideTableKind::kInterpolatory, two_tables(), {"YS", "ZS"});
  ASSERT_TRUE(cec.ok()) << cec.error().message;
  EXPECT_EQ(cec->rfind("%_N_NC_CEC_INI\n", 0), 0u);
  // A CEC value is added to the output axis: the error's opposite.
  EXPECT_THAT(*cec, HasSubstr("$AN_CEC[0,0]=0.0020\n$AN_CEC[0,1]=0.0000\n$AN_CEC[0,2]=-0.0020\n"
                              "$AN_CEC_INPUT_AXIS[0]=(ZS)\n$AN_CEC_OUTPUT_AXIS[0]=(YS)\n$AN_CEC_STEP[0]=2.0000\n"));
  EXPECT_THAT(*cec, HasSubstr("$AN_CEC_DIRECTION[0]=0\n$AN_CEC_MULT_BY_TABLE[0]=0\n$AN_CEC_IS_MODULO[0]=0\nM17\n"));
  for (const auto& [text, names] : {std::pair{*lec, SlideAxisNames{}}, std::pair{*cec, SlideAxisNames{"YS", "ZS"}}}) {
    Result<std::vector<SlideCompensationTable>> back = parse_slide_compensation(text, "F.INI", names);
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_EQ(back->size(), 1u);
    const std::vector<SlideCompensationTable> written = two_tables();
    const SlideCompensationTable& want = written[back->front().kind == SlideTableKind::kLeadscrew ? 0 : 1];
    EXPECT_EQ(back->front().input_axis, want.input_axis);
    EXPECT_EQ(back->front().output_axis, want.output_axis);
    EXPECT_DOUBLE_EQ(back->front().min_mm, want.min_mm);
    ASSERT_EQ(back->front().error_mm.size(), want.error_mm.size());
    for (std::size_t i = 0; i < want.error_mm.size(); ++i) {
      EXPECT_NEAR(back->front().error_mm[i], want.error_mm[i], 0.5e-4);  // the file's 0.1 um
    }
  }
}

TEST(SlideCompensation, AFileEditedOrForeignIsRefusedNamingTheLine) {
  const std::string text = *render_slide_compensation(SlideTableKind::kLeadscrew, two_tables(), {});
  std::string edited = text;
  edited.replace(edited.find("=-0.0031"), 8, "=-0.0032");
  Result<std::vector<SlideCompensationTable>> r = parse_slide_compensation(edited, "AX_EEC.INI", {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kRefused);
  EXPECT_THAT(r.error().message, HasSubstr("AX_EEC.INI: the tables were edited by hand"));
  std::string foreign = text;
  foreign.insert(foreign.find("$AA_ENC_COMP_STEP"), "$MA_BACKLASH[0,Z1]=0.002\n");
  r = parse_slide_compensation(foreign, "AX_EEC.INI", {});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("AX_EEC.INI:15: `$MA_BACKLASH`"));
  r = parse_slide_compensation(text, "AX_EEC.INI", {"Y1", "Z2"});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("axis `Z1` is neither Y (Y1) nor Z (Z2)"));
  // The file names its axes: read without being told them, it holds the tables written.
  const std::string renamed = *render_slide_compensation(SlideTableKind::kLeadscrew, two_tables(), {"Y1", "Z2"});
  EXPECT_THAT(renamed, HasSubstr("; gaugeloop z_axis_name: Z2\n"));
  Result<std::vector<SlideCompensationTable>> own = parse_slide_compensation(renamed, "AX_EEC.INI");
  ASSERT_TRUE(own.ok()) << own.error().message;
  ASSERT_EQ(own->size(), 1u);  // the LEC file holds Z's table alone
  EXPECT_EQ(own->front().output_axis, 'Z');
  EXPECT_EQ(own->front().error_mm.size(), two_tables().front().error_mm.size());
  r = parse_slide_compensation("%_N_TOOL_INI\n", "T.INI", {});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("T.INI:1: the file begins with `%_N_TOOL_INI`"));
  EXPECT_FALSE(render_slide_compensation(SlideTableKind::kLeadscrew, two_tables(), {"Y 1", "Z1"}).ok());
  EXPECT_FALSE(render_slide_compensation(SlideTableKind::kLeadscrew, {}, {}).ok());
}

}  // namespace
}  // namespace gaugeloop
