// The PLC handshake's block of holding registers and its result codes (docs/service.md, "The
// PLC handshake"): the one layout the service (app/), its link (acquisition/) and the PLC
// simulator (simulator/) share.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// Offsets from the configured base address, in the PLC's holding registers (function 03 to
// read, 16 to write). Words 0-2 and 12-36 (37 with the part temperature) are the PLC's; 3-11
// the service's, written in one request. The service reads the whole block, words 0-36 (0-37),
// in one request.
namespace plc_registers {
inline constexpr int kRequest = 0;        // PLC: bit 0 = measure; a rising edge is one request
inline constexpr int kPartNumber = 1;     // PLC: uint16, the [[part]] plc_part_number
inline constexpr int kLobe = 2;           // PLC: uint16, lobe number (1, 2, ...)
inline constexpr int kHeartbeat = 3;      // service: +1 every poll, wraps at 65535
inline constexpr int kAck = 4;            // service: 1 from request seen until the PLC clears it
inline constexpr int kBusy = 5;           // service: 1 while the run is measured and pushed
inline constexpr int kDone = 6;           // service: 1 when the cycle ended with a stored run
inline constexpr int kFault = 7;          // service: 1 when it ended without one (result code says why)
inline constexpr int kResultCode = 8;     // service: PlcResultCode, valid while done or fault is 1
inline constexpr int kRunIdHigh = 9;      // service: run id, uint32, high word first (ABCD)
inline constexpr int kRunIdLow = 10;      //   0 when no run was stored
inline constexpr int kTableVersion = 11;  // service: table version pushed, 0 when none
// PLC: the table version of the part's NC program that ground the part to measure, set with
// the part and lobe numbers: 0 = not said (the table in force is assumed and the part's error
// asked), 1..65534 = that version, 65535 = ground from the design (no table).
inline constexpr int kGroundWith = 12;
inline constexpr std::uint16_t kGroundWithDesign = 0xFFFF;
// PLC: the part's serial number and the operator, ASCII text two characters a word, the first
// in the high byte (an S7 Array of Char, or a STRING's characters without its two length
// bytes, maps onto the registers so: S7 memory is big-endian). The text ends at the first NUL
// byte or with the last word; all words 0: not given. 32 characters hold the serial numbers
// of part marking (DataMatrix serials run 10-25) with room; 16 an operator's badge number or
// short name. Set with the part and lobe numbers, before the request rises.
inline constexpr int kSerialFirst = 13;
inline constexpr int kSerialWords = 16;  // words 13..28, 32 characters
inline constexpr int kOperatorFirst = kSerialFirst + kSerialWords;
inline constexpr int kOperatorWords = 8;  // words 29..36, 16 characters
// PLC, only with [plc] part_temperature = true (the block then has one word more, so a PLC
// program written for the 37-word block keeps working without it): the part's temperature at
// measurement, int16 in 0.1 deg C (214 = 21.4 deg C, -15 = -1.5 deg C);
// kPartTemperatureNotGiven (0x8000, -32768): not given. Set with the part and lobe numbers,
// before the request rises. Values outside kPartTemperatureMinC..MaxC
// (core/part_temperature.h) fault the request (PlcResultCode::kBadPartTemperature).
inline constexpr int kPartTemperature = kOperatorFirst + kOperatorWords;  // word 37
inline constexpr std::uint16_t kPartTemperatureNotGiven = 0x8000;
inline constexpr int kPlcWords = 3;  // words 0..2
inline constexpr int kServiceFirst = kHeartbeat;
inline constexpr int kServiceWords = 9;  // words 3..11
// The block without the part temperature (37 words) and with it (38).
inline constexpr int kBlockWords = kPartTemperature;
inline constexpr int kBlockWordsWithTemperature = kPartTemperature + 1;
// One read (function 03) carries at most 125 registers: the block is read in one request so
// the PLC's words are always from one moment.
static_assert(kBlockWordsWithTemperature <= 125, "the handshake block must fit one Modbus read");
inline constexpr std::uint16_t kMeasureBit = 0x0001;
}  // namespace plc_registers

// What became of one PLC request. 0-2: done (a run was stored); 3 and up: fault (no run, or
// one stored whose table could not be written). Codes are only ever added, never renumbered.
enum class PlcResultCode : std::uint16_t {
  kTablePushed = 0,          // run stored, its curve table pushed
  kTableHeld = 1,            // run stored, table kept for approval (`gaugeloop nc approve`)
  kTableRefused = 2,         // run stored, the correction refused: the table in force stays
  kUnknownPart = 3,          // part number or lobe not in the configuration; nothing measured
  kGaugeFault = 4,           // the gauge did not answer or the run was incomplete; nothing stored
  kStorageFault = 5,         // the run database refused the run
  kNcFault = 6,              // the NC program could not be written
  kNotNow = 7,               // another run in progress (HTTP, by hand) or the service stopping
  kOtherFault = 8,           // anything else: the service log and `gaugeloop events` say what
  kBadIdentity = 9,          // the serial number or operator words hold a byte that is not text; nothing measured
  kBadPartTemperature = 10,  // the part temperature word is outside -40.0..150.0 deg C; nothing measured
};

// The PLC's words (0-2, 12-37), as read.
struct PlcRequestWords {
  std::uint16_t request = 0;
  std::uint16_t part_number = 0;
  std::uint16_t lobe = 0;
  std::uint16_t ground_with = 0;                                             // word 12, as read
  std::array<std::uint16_t, plc_registers::kSerialWords> serial{};           // words 13..28, as read
  std::array<std::uint16_t, plc_registers::kOperatorWords> operator_name{};  // words 29..36, as read
  std::uint16_t part_temperature = plc_registers::kPartTemperatureNotGiven;  // word 37, as read
  bool measure() const { return (request & plc_registers::kMeasureBit) != 0; }
  // The table version that ground the part: empty when not said (0), 0 for the design.
  std::optional<int> ground_with_version() const {
    if (ground_with == 0) return std::nullopt;
    if (ground_with == plc_registers::kGroundWithDesign) return 0;
    return ground_with;
  }
};

// The service's words (3-11), as written.
struct PlcServiceWords {
  std::uint16_t heartbeat = 0;
  bool ack = false;
  bool busy = false;
  bool done = false;
  bool fault = false;
  PlcResultCode result_code = PlcResultCode::kTablePushed;
  std::uint32_t run_id = 0;
  std::uint16_t table_version = 0;
  bool operator==(const PlcServiceWords&) const = default;
};

// Text as the PLC writes it into `words`: two bytes a word, the first in the high byte, the
// rest NUL. Bytes are taken as they are (a test may write a control byte). kInvalidInput when
// the text has more bytes than the words hold (2 a word).
Status encode_plc_text(std::string_view text, std::span<std::uint16_t> words);

// The text the PLC wrote into `words` (see kSerialFirst): up to the first NUL byte, spaces
// at either end trimmed (an S7 Char array is often padded with spaces); empty when the words
// are all 0 or spaces. Bytes after the first NUL are not read. kInvalidInput when a byte
// before it is not printable ASCII (0x20..0x7E), naming `what` ("serial number"), the word
// (its offset `first_word` + i and its holding register `base_address` + offset), which
// byte (high, low) and its value.
Result<std::string> decode_plc_text(std::span<const std::uint16_t> words, int first_word, int base_address,
                                    std::string_view what);

// The part temperature the PLC wrote into word 37 (kPartTemperature), deg C: empty when not
// given (kPartTemperatureNotGiven). kInvalidInput naming the word, its holding register
// (`base_address` + 37), the value read and what to write, when it is outside
// kPartTemperatureMinC..kPartTemperatureMaxC.
Result<std::optional<double>> decode_plc_part_temperature(std::uint16_t word, int base_address);

// Word 37 as the PLC writes it for `temperature_c` (rounded to 0.1 deg C; empty: not given).
// Any value an int16 in 0.1 deg C holds is written, also one the service refuses, so a test can
// play a PLC that writes nonsense. kInvalidInput for a value not finite or beyond the word.
Result<std::uint16_t> encode_plc_part_temperature(std::optional<double> temperature_c);

// Words 3..11 in register order (run id high word first); decode is the inverse.
std::array<std::uint16_t, plc_registers::kServiceWords> encode_service_words(const PlcServiceWords& w);
PlcServiceWords decode_service_words(const std::array<std::uint16_t, plc_registers::kServiceWords>& regs);

// "table pushed", "unknown part", ...
std::string_view plc_result_name(PlcResultCode code);

// True for the codes answered with done (a run stored), false for those answered with fault.
inline bool plc_result_is_done(PlcResultCode code) { return static_cast<std::uint16_t>(code) <= 2; }

}  // namespace gaugeloop
