// The main program (.MPF) that loads the curve table and couples the wheel infeed to it,
// rendered from the user's template beside each table.
//
// Placeholders (docs/nc_output.md): program_name (the table subprogram it calls), part, lobe,
// version (gaugeloop's), run_id, created_utc, table_version, table_number (the table the
// subprogram just defined, the one to couple), table_start_c_deg (the table's first leading
// value, 0.000 or a start on the base circle), point_count, interpolation. Any other, or one
// left unfilled, is refused as for the table (render_nc_template). A crankpin ground C-X-Y
// adds y_program_name (the Y table's subprogram) and y_table_number (the table it defines).
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// Renders `template_text` with `values` (which must hold "program_name" and "table_number"),
// then reads the result back: it must call the subprogram program_name (a block whose first
// word, after an optional block number, is that name, or EXTCALL("<that name>")) and couple through table_number (an
// EGON(following axis, block change, leading axis, table, 0) or LEADON(following axis, leading
// axis, table) naming it), and every coupling it makes must name that table, so a template
// that couples a fixed number never ships. kInvalidInput naming the template otherwise.
//
// A crankpin ground C-X-Y couples two tables to C: when `values` hold "y_program_name" and
// "y_table_number" (both or neither), the program must call both subprograms, couple X through
// table_number and Y through y_table_number, each axis only to its own table and no other
// axis, and the two numbers must differ. Without them (a lobe, or a pin ground C-X) the rule
// above holds unchanged.
//
// A correction layer: when `values` hold "design_program_name" and "design_table_number"
// (both or neither), the program must call both subprograms, couple X through one EGON to
// two leading axes, C through the design table and SIM1 through table_number (each with
// denominator 0, a curve table), couple SIM1 to C 1:1 (numerator equal to denominator) and
// nothing else; the two numbers must differ.
Result<std::string> render_main_program(std::string_view template_text, std::string_view template_name,
                                        const std::map<std::string, std::string>& values);

// The Y table's subprogram of a crankpin ground C-X-Y: <program_name>_Y (CRANK_PIN1_XY ->
// CRANK_PIN1_XY_Y), the file that defines the Y table beside the X table's <program_name>.
std::string pin_y_program_name(std::string_view program_name);

// The design table's subprogram of a correction layer: <program_name>_DESIGN (CAM ->
// CAM_DESIGN). It defines the design's whole table, coupled X to C; the layer <program_name>
// holds the correction alone, X to the virtual axis SIM1 following C, and the electronic
// gearbox adds the two (docs/nc_output.md, "The correction as a layer"). Written from the
// drawing and never by a push.
std::string design_program_name(std::string_view program_name);

// The speed subprogram of a table subprogram: <program_name>_SPEED (CAM -> CAM_SPEED), the
// file the main program calls for one turn of C at the programmed work speed
// (nc_out/speed_table.h). A main program template names it as {{program_name}}_SPEED.
std::string speed_program_name(std::string_view program_name);

// Refuses (kInvalidInput, naming `file_name`) a rendered main program with no block that calls
// `speed_subprogram` (its first word, after an optional block number, with or without a
// repetition such as `P10`): with a speed program on, a main program that ignores it grinds at
// one speed unannounced.
Status check_main_calls_speed_program(std::string_view program, std::string_view file_name,
                                      std::string_view speed_subprogram);

// The table number the first EGON or LEADON of `program` couples through (a crankpin's X
// table when its template couples X first, as examples/sinumerik/pin_main.mpf does), or with
// `following_axis` the first that couples that axis; kInvalidInput naming `file_name` and the
// line if it has none or it cannot be read. A correction layer's main program: the table
// coupled from the virtual axis SIM1 (the layer, the table pushed), not the design table.
Result<int> coupled_table_number(std::string_view program, std::string_view file_name,
                                 std::string_view following_axis = {});

// The main program of a gear's stroke (docs/gears.md): `values` must hold "program_name" (the
// stroke subprogram) and "gearbox_coupling" (render_gearbox_coupling's EGDEF and EGON lines,
// nc_out/stroke_program.h), and may hold part, version, run_id, origin, created_utc,
// table_version, point_count and sim_max_abs_deg. The rendered program must hold the gearbox's
// lines as blocks, in order, before the block that calls program_name, and make no other
// coupling (EGDEF, EGON, EGONSYN, LEADON, TRAILON), so a template without {{gearbox_coupling}},
// or with a gearbox of its own, never ships. kInvalidInput naming the template and line.
Result<std::string> render_gear_main_program(std::string_view template_text, std::string_view template_name,
                                             const std::map<std::string, std::string>& values);

}  // namespace gaugeloop
