// The command line's vocabulary: usage errors, and the CLI11 validators every command uses, so that
// a malformed option is refused while parsing, with one line naming the option, before any input
// is opened.
#pragma once

#include "core/edit_distance.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "metrics/sphere_metrics.h"

namespace isoslab::cli {

/// A command line that cannot work whatever the input holds (a malformed list, an unknown name, a
/// missing value): one line on stderr and exit status 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// "a, b, c or d".
std::string alternatives(const std::vector<std::string>& names);

/// A transform that takes one of `names` in any case and hands the option the name as listed;
/// otherwise "unknown WHAT 'value' (use a, b or c)".
CLI::Validator oneOf(const std::string& what, const std::vector<std::string>& names);

/// A comma-separated list of `names` (each in any case, rewritten as listed); otherwise "unknown
/// WHAT 'item' (use a, b or c)".
CLI::Validator listOf(const std::string& what, const std::vector<std::string>& names);

/// A floating-point option whose number must be finite ("nan", "inf" and "1e400" are refused).
/// Other text is CLI11's to refuse.
CLI::Validator finiteNumber();
/// A finite number of 0 or more (CLI::NonNegativeNumber takes NaN and prints its range whole).
CLI::Validator nonNegativeNumber();

/// --iso: a finite number, `auto`, or a named CT value (stream/iso_choice.h: bone, skin), names in any
/// case and rewritten in lower case; otherwise "'TEXT' is not a number, auto, bone or skin" ("'nan' is
/// not a finite number" for a number that is not finite).
CLI::Validator isoValue();

/// An integer option: the whole text, within [lo, hi]; `meaning` follows the range in the message.
CLI::Validator integerIn(std::int64_t lo, std::int64_t hi, const std::string& meaning = "");

/// A comma-separated list of finite numbers ("'TEXT' is not a comma-separated list of numbers"),
/// which `check` then judges: it returns "" or the rest of the message after "'TEXT' ", e.g.
/// "needs three values".
CLI::Validator numberList(std::function<std::string(const std::vector<double>&)> check);

/// The numbers of a list; throws UsageError naming `option` when the text is not one (numberList()
/// has already refused such text on the command line).
std::vector<double> parseList(const std::string& text, const std::string& option);

/// --sphere cx,cy,cz,r (extract and metrics): four numbers with r > 0.
CLI::Validator sphereList();
/// The sphere of a --sphere text that sphereList() accepted.
Sphere parseSphere(const std::string& text);

/// An option of `command` (or of a subcommand it parsed) that took one of the command's own option
/// names as its value (`--report --quiet`: CLI11 takes the next word whatever it is), as
/// "--report needs a value, not the option --quiet"; "" when none did.
std::string optionTakenAsValue(const CLI::App& command);

/// Library text with the settings it names (core/error.h: `channel`, `raw_dims`, ...) spelled as
/// this program's options (--channel, --raw-dims). Other text, backticks included, is kept.
std::string withFlags(const std::string& text);

/// `text` made safe for one line of a terminal: newline, tab and carriage return as \n, \t, \r;
/// other control characters (C0, DEL and the C1 controls U+0080..U+009F) and every byte that does
/// not start a well-formed UTF-8 sequence as \xNN; well-formed UTF-8 ("tête.nii") kept.
std::string terminalLine(const std::string& text);

/// Levenshtein distance, for "did you mean".

}  // namespace isoslab::cli
