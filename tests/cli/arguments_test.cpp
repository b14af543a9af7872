// cli/arguments: the validators, parsed through a real CLI11 app, and the spelling of library
// settings as options.
#include "cli/arguments.h"

#include <gtest/gtest.h>

#include "test_support.h"

namespace isoslab::cli {
namespace {

// Parses `args` for one option --x with `validator`; returns CLI11's message, or "ok: VALUE".
std::string parse(const CLI::Validator& validator, const std::vector<std::string>& args) {
  CLI::App app;
  std::string value;
  app.add_option("--x", value)->transform(validator);
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return e.what();
  }
  return "ok: " + value;
}

TEST(Arguments, OneOfAndListOfTakeAnyCaseAndRewriteTheNames) {
  EXPECT_EQ(parse(oneOf("space", {"lps", "ras"}), {"--x", "RaS"}), "ok: ras");
  EXPECT_EQ(parse(oneOf("space", {"lps", "ras"}), {"--x", "xyz"}), "--x: unknown space 'xyz' (use lps or ras)");
  EXPECT_EQ(parse(listOf("method", {"mc", "mt5", "bcc12"}), {"--x", "MC,bcc12"}), "ok: mc,bcc12");
  EXPECT_EQ(parse(listOf("method", {"mc", "mt5", "bcc12"}), {"--x", "mc,,mt5"}),
            "--x: unknown method '' (use mc, mt5 or bcc12)");
}

TEST(Arguments, NumberListRefusesNonFiniteItemsThenAsksItsCheck) {
  const CLI::Validator three =
      numberList([](const std::vector<double>& v) -> std::string { return v.size() == 3 ? "" : "needs three values"; });
  EXPECT_EQ(parse(three, {"--x", "1,2.5,-3"}), "ok: 1,2.5,-3");
  EXPECT_EQ(parse(three, {"--x", "1,2"}), "--x: '1,2' needs three values");
  for (const std::string bad : {"1,nan,3", "1,,3", "1,2,", "1,2,3x", "1e400,2,3", ""}) {
    EXPECT_EQ(parse(three, {"--x", bad}), "--x: '" + bad + "' is not a comma-separated list of numbers") << bad;
  }
  EXPECT_EQ(parseList("4,-0.5,1e3", "--x"), (std::vector<double>{4, -0.5, 1000}));
  EXPECT_THROW(parseList("4,inf", "--x"), UsageError);
}

TEST(Arguments, IntegersAndFiniteNumbers) {
  EXPECT_EQ(parse(integerIn(1, 8), {"--x", "8"}), "ok: 8");
  EXPECT_EQ(parse(integerIn(1, 8), {"--x", "9"}), "--x: '9' is not a whole number from 1 to 8");
  EXPECT_EQ(parse(integerIn(1, 8), {"--x", "2.0"}), "--x: '2.0' is not a whole number from 1 to 8");
  EXPECT_EQ(parse(finiteNumber(), {"--x", "-1e3"}), "ok: -1e3");
  EXPECT_EQ(parse(finiteNumber(), {"--x", "-inf"}), "--x: '-inf' is not a finite number");
  EXPECT_EQ(parse(finiteNumber(), {"--x", "1e999"}), "--x: '1e999' is not a finite number");
  // --min-volume's check: CLI::NonNegativeNumber took NaN and printed its range in 309 digits.
  EXPECT_EQ(parse(nonNegativeNumber(), {"--x", "0"}), "ok: 0");
  EXPECT_EQ(parse(nonNegativeNumber(), {"--x", "2.5e3"}), "ok: 2.5e3");
  for (const std::string bad : {"nan", "-1", "inf", "1e400", "-0.5", "x"}) {
    EXPECT_EQ(parse(nonNegativeNumber(), {"--x", bad}), "--x: '" + bad + "' is not a finite number of 0 or more");
  }
  const auto keep = isoslab::testing::runCli("extract phantom:voxel --keep-largest 18446744073709551616 -o x.ply");
  EXPECT_EQ(keep.exitCode, 2);
  EXPECT_EQ(keep.err,
            "isoslab: error: --keep-largest: '18446744073709551616' is not a whole number from 1 to "
            "9223372036854775807\n");
}

// Library messages name settings in backticks (core/error.h); the program spells them as options.
TEST(Arguments, WithFlagsSpellsKnownSettingsAsOptions) {
  EXPECT_EQ(withFlags("`channel`: a.dcm has 3 samples; choose one with `channel` 0..2"),
            "--channel: a.dcm has 3 samples; choose one with --channel 0..2");
  EXPECT_EQ(withFlags("give `raw_dims` X,Y[,Z] and `raw_type`"), "give --raw-dims X,Y[,Z] and --raw-type");
  // A file name with backticks, or an unknown word between them, is left alone.
  EXPECT_EQ(withFlags("/tmp/`x`/a`b: `colour` `"), "/tmp/`x`/a`b: `colour` `");
  EXPECT_EQ(withFlags("`series``strict`"), "--series--strict");
  EXPECT_EQ(withFlags(""), "");
}

// What errors and warnings print: one line, no byte a terminal could act on, UTF-8 kept (issue 33).
TEST(TerminalLine, EscapesControlsAndBytesThatAreNotUtf8) {
  EXPECT_EQ(terminalLine("plain.nii"), "plain.nii");
  EXPECT_EQ(terminalLine("t\xc3\xaate.nii \xe2\x82\xac \xf0\x9f\x98\x80"),
            "t\xc3\xaate.nii \xe2\x82\xac \xf0\x9f\x98\x80");
  EXPECT_EQ(terminalLine("a\nb\tc\rd\x1b[31m\x7f"), "a\\nb\\tc\\rd\\x1b[31m\\x7f");
  EXPECT_EQ(terminalLine("q\xff.nrrd"), "q\\xff.nrrd");                 // never a UTF-8 byte
  EXPECT_EQ(terminalLine("\xc2\x9b"), "\\xc2\\x9b");                    // C1 CSI, well-formed
  EXPECT_EQ(terminalLine("\xc0\xaf"), "\\xc0\\xaf");                    // overlong '/'
  EXPECT_EQ(terminalLine("\xed\xa0\x80"), "\\xed\\xa0\\x80");           // a surrogate
  EXPECT_EQ(terminalLine("\xf4\x90\x80\x80"), "\\xf4\\x90\\x80\\x80");  // past U+10FFFF
  EXPECT_EQ(terminalLine("\xe2\x82"), "\\xe2\\x82");                    // cut short
  EXPECT_EQ(terminalLine("\x80x"), "\\x80x");                           // a stray continuation
}

}  // namespace
}  // namespace isoslab::cli
