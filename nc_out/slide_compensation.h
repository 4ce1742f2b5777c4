// The slides' compensation tables as the SINUMERIK 840D loads them (Function Manual *Extended
// Functions*, K3 Compensations, "Interpolatory compensation", 03/2013, 6FC5397-1BP40-3BA1):
//   - leadscrew error compensation (LEC), the file %_N_AX_EEC_INI: for each axis
//       $AA_ENC_COMP[0,N,Y1]=<value>      ; a positive value moves the axis negative
//       $AA_ENC_COMP_STEP[0,Y1]=<mm>  $AA_ENC_COMP_MIN[0,Y1]=<mm>  $AA_ENC_COMP_MAX[0,Y1]=<mm>
//       $AA_ENC_COMP_IS_MODULO[0,Y1]=0
//   - sag and angularity compensation (CEC), the file %_N_NC_CEC_INI: for each table t
//       $AN_CEC[t,N]=<value>              ; added to the output axis' position
//       $AN_CEC_INPUT_AXIS[t]=(Z1)  $AN_CEC_OUTPUT_AXIS[t]=(Y1)
//       $AN_CEC_STEP[t]  $AN_CEC_MIN[t]  $AN_CEC_MAX[t]  $AN_CEC_DIRECTION[t]=0
//       $AN_CEC_MULT_BY_TABLE[t]=0  $AN_CEC_IS_MODULO[t]=0
// each file CHANDATA(1) ... M17, with gaugeloop's header comments (kind, checksum, point counts)
// after its first line. The values are in mm, rounded to 0.1 um. Pure text: no I/O.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "core/slide_table.h"

namespace gaugeloop {

// The machine axes' names the tables address (MD10000 $MN_AXCONF_MACHAX_NAME_TAB).
struct SlideAxisNames {
  std::string y = "Y1";
  std::string z = "Z1";
};

// The file of one kind of table: every table of `tables` of that kind (LEC: one per axis; CEC:
// numbered from 0 in order). kInvalidInput for no table of that kind, a table without points,
// a step not positive, a value not finite, two LEC tables of one axis, a name that is not a
// machine axis' (letters, digits, underscore), or an LEC table whose input and output differ.
Result<std::string> render_slide_compensation(SlideTableKind kind, const std::vector<SlideCompensationTable>& tables,
                                              const SlideAxisNames& names,
                                              const std::map<std::string, std::string>& header = {});

// The file name a control's file of that kind is loaded from: "AX_EEC.INI", "NC_CEC.INI".
std::string_view slide_compensation_file_name(SlideTableKind kind);

// Whether `text` is a slides' compensation file gaugeloop wrote: its header (before the body)
// says `; gaugeloop kind: slide compensation`.
bool is_slide_compensation(std::string_view text);

// The `; gaugeloop key: value` lines before the body of a program or table file (a curve table,
// a stroke, a slides' file): its header as written.
std::map<std::string, std::string> program_header(std::string_view text);

// Reads what render_slide_compensation writes (the tables with the errors they take out, in the
// order written). Anything else is refused naming the line; kRefused when the body does not
// match the header's checksum (edited by hand); kInvalidInput for a file without one, a table
// whose MAX is not MIN + STEP x (points - 1), an axis not in `names`.
Result<std::vector<SlideCompensationTable>> parse_slide_compensation(std::string_view text, std::string_view file_name,
                                                                     const SlideAxisNames& names);
// The same with the axes' names the file's header gives (`y_axis_name`, `z_axis_name`, written
// by render_slide_compensation); Y1 and Z1 for a file whose header has none.
Result<std::vector<SlideCompensationTable>> parse_slide_compensation(std::string_view text, std::string_view file_name);

}  // namespace gaugeloop
