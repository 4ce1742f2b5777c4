// The rendered table program (.SPF): header comment, checksum, rendering from the user's
// template, and reading a pushed program back.
//
// Frame and units as curve_table.h: C in degrees (leading axis), X in mm (following axis);
// a crankpin's Y table has Y in mm as its following axis, everything else alike.
//
// Header: comment lines `; gaugeloop <key>: <value>` that the template places with
// {{table_header}}. Keys: run_id, table_version, table_number and table_numbers (when the
// table's pair of numbers is known), interpolation (linear | cspline), point_count,
// block_count, command_error_um, command_error_at_c_deg, seam_c_deg (the table's first leading
// value: where a periodic table closes on itself), writer, grinding_cycle (the main program's
// passes, when known), part, lobe and pin_mode (when known), body_checksum_fnv1a64.
//
// Checksum: 64-bit FNV-1a (offset basis 14695981039346656037, prime 1099511628211) over the
// bytes of the table body, i.e. the lines strictly between the CTABDEF line and the CTABEND
// line, joined with "\n" (carriage returns removed, so a CR LF copy still verifies, no
// newline after the last line); written as 16 lower-case hex digits. Not a protection
// against intent, only against a hand edit going unnoticed.
//
// Archive header: optional first two lines in the Sinumerik punched-tape (archive) format,
// `%_N_<NAME>_SPF` and `;$PATH=/_N_SPF_DIR` (main programs `_MPF`, `/_N_MPF_DIR`), so the
// HMI loads the file as it is into the NC's program directory. Outside the table: the parser,
// the checksum and the comparison of points ignore them.
//
// Errors: kInvalidInput for a program that does not parse (naming the file and 1-based line);
// kRefused for a table edited by hand (checksum or points), naming the file and line.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "nc_out/curve_table.h"
#include "nc_out/table_writer.h"

namespace gaugeloop {

enum class NcProgramKind {
  kSubprogram,   // .SPF, /_N_SPF_DIR
  kMainProgram,  // .MPF, /_N_MPF_DIR
};

// The archive header for program `name` (the file's stem, e.g. CAM_INTAKE_L1), two lines each
// ending in "\n". kInvalidInput naming the program unless the name is 1..24 letters, digits or
// '_' (the HMI's rule for a file name in punched-tape format).
Result<std::string> archive_header(std::string_view name, NcProgramKind kind);

// True when `program` starts with an archive header line: '%' in the first column of the
// first line.
bool has_archive_header(std::string_view program);

// FNV-1a 64 of `body` with every '\r' skipped, 16 lower-case hex digits.
std::string table_body_checksum(std::string_view body);

// The header lines gaugeloop writes into its programs (table and speed subprogram):
// `; gaugeloop <key>: <value>`. Appends one to `out`, after a '\n' unless `out` is empty.
void append_header_line(std::string& out, std::string_view key, std::string_view value);
// True when `line` (trimmed) is such a header line; its key and value then go into `header`.
bool read_header_line(std::string_view line, std::map<std::string, std::string>& header);

// The two CTABDEF numbers a program's tables alternate between (docs/nc_output.md): the table
// of version v goes to numbers[(v - 1) % 2], so the next version never redefines the table
// the main program couples now. Version 0 (a pending table, its version not yet known) takes
// numbers[0]; its push sets the number with the version.
using TableNumbers = std::array<int, 2>;
int table_number_for_version(const TableNumbers& numbers, std::int64_t table_version);

// Where a table comes from, for the header.
struct TableProvenance {
  std::int64_t run_id = 0;
  std::int64_t table_version = 0;  // the push's version, counted by storage
  // {0, 0}: not known (the header has no table_number lines, {{table_number}} is the
  // caller's). Otherwise {{table_number}} is table_number_for_version and the header names it.
  TableNumbers table_numbers{0, 0};
  // The main program's passes from blank to size (grinding_cycle_text, nc_out/infeed.h), for a
  // main program rendered from this table's text; empty: no such header line.
  std::string grinding_cycle{};
  // What the table grinds, for a main program rendered from the text alone (a rollback to a
  // program written from the drawing, which has no run to ask): the part, its lobe or pin
  // number, and for a crankpin its mode ("c-x", "c-x-y"). Empty: no such header lines.
  std::string part{};
  int lobe = 0;
  std::string pin_mode{};
  // A correction layer (docs/nc_output.md, "The correction as a layer"): the table is the
  // correction alone, X against the virtual axis SIM1 that follows C, summed by the gearbox
  // with the design table `design_table_number` that the subprogram `design_program` defines.
  // The header names both (keys design_program, design_table_number), {{leading_axis}} is
  // SIM1 and the CTABDEF read back must name it. Empty: a whole table, leading axis C.
  std::string design_program{};
  int design_table_number = 0;
  // The design table under a correction layer: the layer's program, for {{table_note}} (not a
  // header line). Empty: not a design table.
  std::string layer_program{};
};

// The virtual leading axis a correction layer is a table of (MD30132 $MA_IS_VIRTUAL_AX = 1,
// a modulo rotary axis following C 1:1 in the main program).
inline constexpr std::string_view kLayerLeadingAxis = "SIM1";

// The header comment block for `table` whose rendered body is `body`; lines joined with
// "\n", none after the last.
std::string render_table_header(const CurveTable& table, const TableProvenance& provenance, std::string_view body);

// Renders the user's table template with `values` plus the table's own placeholders:
// table_blocks, table_header, point_count, block_count, interpolation, command_error_um, and
// table_number when provenance.table_numbers is known (the CTABDEF read back must name it),
// leading_axis (C, or SIM1 for a correction layer: the CTABDEF read back must name it),
// table_subject ("lobe 1", "pin 1") and table_note (one comment line saying what the following
// axis holds: a lobe's infeed from the base circle, a pin's from its farthest position, a
// correction layer's correction alone, a design table's whole path).
// The blocks carry the following axis the template's CTABDEF names: CTABDEF(X,C,..) for the
// infeed, CTABDEF(Y,C,..) for the wheel height of a crankpin ground C-X-Y (X when it names
// none that can be read; the read-back then refuses it).
// Then reads the result back (parse_table_program) and refuses (kInvalidInput, naming the
// template) unless it gives exactly table.points, the interpolation and a matching checksum,
// so a template that puts text inside the table or leaves {{table_blocks}} out never ships.
Result<std::string> render_table_program(std::string_view template_text, std::string_view template_name,
                                         std::map<std::string, std::string> values, const CurveTable& table,
                                         const TableProvenance& provenance, const CurveTableFormat& format = {});

// A table program read back.
struct ParsedTable {
  std::string following_axis;  // CTABDEF's first argument, e.g. "X"
  std::string leading_axis;    // e.g. "C"
  int table_number = 0;
  int periodicity = 0;
  Interpolation interpolation = Interpolation::kLinear;
  bool natural_ends = false;  // CSPLINE with BNAT and ENAT: the only spline gaugeloop models
  std::vector<CurvePoint> points;
  std::vector<int> point_lines;  // 1-based line of each point's block
  int ctabdef_line = 0;
  int ctabend_line = 0;
  std::map<std::string, std::string> header;  // `; gaugeloop key: value` lines
  std::string body_checksum;                  // computed over the body as read
};

// Parses a program holding exactly one CTABDEF .. CTABEND. Inside, blocks may carry a block
// number (N10), G1, CSPLINE, BNAT/ENAT/BAUTO/EAUTO/BTAN/ETAN, POLY, the leading and following
// axis with a value (C12.5 or C=12.5) or as a polynomial (PO[C]=(end), PO[X]=(end,a2,a3)) and a
// comment after ';'. X is modal (a block without it keeps the last X); every block needs C.
// Anything else (PL among it) is refused with its line: gaugeloop cannot say what the control
// would make of it. Mixed interpolations (G1 and CSPLINE, ...) are refused.
Result<ParsedTable> parse_table_program(std::string_view text, std::string_view file_name);

// Refuses (kRefused) a table whose body does not match the checksum in its header, or whose
// point count differs from the header's: it was edited by hand since gaugeloop wrote it.
// kInvalidInput if there is no checksum in the header (not a gaugeloop table).
Status verify_table_checksum(const ParsedTable& table, std::string_view file_name);

// Refuses (kRefused) a table whose points differ from `expected` (as written with `format`),
// naming the first line that differs, the value read and the value pushed.
Status compare_table_points(const ParsedTable& table, const std::vector<CurvePoint>& expected,
                            std::string_view file_name, const CurveTableFormat& format = {});

}  // namespace gaugeloop
