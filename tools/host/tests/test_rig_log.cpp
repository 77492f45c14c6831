// Rig-log CSV reader: contract of interfaces.md (strict, line-numbered, counts, refuses).
#include <gtest/gtest.h>
#include <sstream>
#include "sma_tools/rig_log.hpp"

using sma_tools::Error;
using sma_tools::LogReadOptions;
using sma_tools::parse_rig_log;
using sma_tools::RigLog;

namespace {

RigLog parse(const std::string& text, LogReadOptions o = LogReadOptions()) {
  std::istringstream in(text);
  return parse_rig_log(in, "log.csv", o);
}

std::string error_of(const std::string& text, LogReadOptions o = LogReadOptions()) {
  try {
    parse(text, o);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string rows(int n, double t0 = 0.0) {
  std::string s;
  for (int k = 0; k < n; ++k) s += std::to_string(t0 + 0.01 * k) + ",1.0,0.5\n";
  return s;
}

}  // namespace

TEST(RigLog, ReadsRequiredOptionalUnknownAndComments) {
  const RigLog log = parse(
      "# rig: test\n"
      "t_s, v_V ,d_mm,ref_mm,duty,f_N,extra\r\n"
      "0.00,0.5,0.01,0.2,0.01,2.7,x\n"
      "\n"
      "# a comment in the middle\n"
      "0.01,0.6,0.02,0.2,0.0144,2.8,y\n");
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log.comments.size(), 2u);
  EXPECT_EQ(log.comments[0], "rig: test");
  EXPECT_TRUE(log.has_ref() && log.has_duty() && log.has_f());
  EXPECT_EQ(log.ignored.size(), 1u);
  EXPECT_EQ(log.ignored[0], "extra");
  EXPECT_DOUBLE_EQ(log.v[1], 0.6);
  EXPECT_DOUBLE_EQ(log.f[1], 2.8);
  EXPECT_EQ(log.line[1], 6);
  EXPECT_EQ(log.dropped, 0);
}

TEST(RigLog, ColumnsInAnyOrderAndOptionalAbsent) {
  const RigLog log = parse("d_mm,t_s,v_V\n0.3,0,1\n0.4,1,1\n");
  EXPECT_FALSE(log.has_ref());
  EXPECT_DOUBLE_EQ(log.d[1], 0.4);
  EXPECT_DOUBLE_EQ(log.t[1], 1.0);
}

TEST(RigLog, MissingRequiredColumnIsNamed) {
  const std::string e = error_of("# c\nt_s,v_V,ref_mm\n0,1,2\n");
  EXPECT_NE(e.find("log.csv:2"), std::string::npos) << e;
  EXPECT_NE(e.find("'d_mm'"), std::string::npos) << e;
}

TEST(RigLog, DuplicateColumnAndNoHeader) {
  EXPECT_NE(error_of("t_s,v_V,d_mm,d_mm\n").find("appears twice"), std::string::npos);
  EXPECT_NE(error_of("# only comments\n").find("no header"), std::string::npos);
}

TEST(RigLog, BadRowsAreDroppedWithLineNumbers) {
  LogReadOptions o;
  o.max_bad_fraction = 0.5;
  const RigLog log = parse("t_s,v_V,d_mm\n" + rows(10) +
                               "0.5,abc,0.1\n"      // line 12: text
                               "0.6,1.0\n"          // line 13: missing field
                               "0.7,nan,0.1\n"      // line 14: NaN
                               "0.05,1.0,0.1\n"     // line 15: time backwards
                               "0.8,1.0,0.1,9\n"    // line 16: extra field
                               "0.9,1.0,inf\n"      // line 17: inf
                               "1.0,1.0,0.2\n",
                           o);
  EXPECT_EQ(log.size(), 11u);
  EXPECT_EQ(log.dropped, 6);
  ASSERT_EQ(log.problems.size(), 6u);
  EXPECT_NE(log.problems[0].find("log.csv:12: column 'v_V': 'abc'"), std::string::npos) << log.problems[0];
  EXPECT_NE(log.problems[1].find("log.csv:13: 2 fields, the header has 3"), std::string::npos) << log.problems[1];
  EXPECT_NE(log.problems[2].find("log.csv:14"), std::string::npos);
  EXPECT_NE(log.problems[3].find("log.csv:15: time"), std::string::npos) << log.problems[3];
  EXPECT_NE(log.problems[4].find("log.csv:16"), std::string::npos);
  EXPECT_NE(log.problems[5].find("log.csv:17"), std::string::npos);
  EXPECT_NE(sma_tools::dropped_note(log).find("dropped 6 bad rows of 17"), std::string::npos);
}

TEST(RigLog, TooManyBadRowsRefusesTheFile) {
  // 1 bad row in 101 is within the default 1 %; 2 are not.
  EXPECT_EQ(error_of("t_s,v_V,d_mm\n" + rows(100) + "9,x,0\n"), "");
  const std::string e = error_of("t_s,v_V,d_mm\n" + rows(100) + "9,x,0\n10,y,0\n");
  EXPECT_NE(e.find("refused: 2 bad rows of 102"), std::string::npos) << e;
  EXPECT_NE(e.find("log.csv:102"), std::string::npos) << e;
  EXPECT_NE(e.find("log.csv:103"), std::string::npos) << e;
}

TEST(RigLog, EqualTimeIsNotIncreasing) {
  LogReadOptions o;
  o.max_bad_fraction = 1.0;
  const RigLog log = parse("t_s,v_V,d_mm\n0,1,1\n1,1,1\n1,1,1\n2,1,1\n", o);
  EXPECT_EQ(log.size(), 3u);
  EXPECT_EQ(log.dropped, 1);
}

TEST(RigLog, TooFewRows) {
  EXPECT_NE(error_of("t_s,v_V,d_mm\n0,1,1\n").find("only 1 valid rows"), std::string::npos);
}

TEST(RigLog, MissingFile) {
  try {
    sma_tools::read_rig_log("/nonexistent/x.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/x.csv: cannot open"), std::string::npos);
  }
}

TEST(RigLog, OnlyPlainDecimalsAreNumbersAndABomIsNotData) {
  // Found by fuzz_rig_log: strtod alone reads "0x1p3" as 8 and skips a leading \v or \f.
  LogReadOptions o;
  o.max_bad_fraction = 1.0;
  const RigLog log = parse("t_s,v_V,d_mm\n0,0,0\n0.01,0x1p3,0\n0.02,\v1,0\n0.03,1e-2,.5\n0.04,-1.,+2\n", o);
  EXPECT_EQ(log.dropped, 2);
  ASSERT_EQ(log.size(), 3u);
  EXPECT_DOUBLE_EQ(log.v[1], 0.01);
  EXPECT_DOUBLE_EQ(log.d[1], 0.5);
  EXPECT_DOUBLE_EQ(log.v[2], -1.0);
  // A UTF-8 byte-order mark before the header (spreadsheet exports) is skipped.
  EXPECT_EQ(parse("\xEF\xBB\xBFt_s,v_V,d_mm\n0,0,0\n0.01,1,0.1\n").size(), 2u);
}
