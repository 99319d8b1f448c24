// The layout of the programs' JSON files: scripts read them line by line (tests/dds/*.sh).

#include "mlmap/eval/json_output.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace mlmap::eval {
namespace {

TEST(JsonOutput, OuterLevelsOneMemberPerLineDeeperOnOneLine) {
  Json doc;
  doc["topics"] = Json::object();
  doc["topics"]["b/x"] = {{"messages", 3}, {"age_ms", {{"median", 1.5}, {"p99", 2.0}}}};
  doc["topics"]["a"] = {{"messages", 1}};
  doc["missing"] = Json::array();
  doc["precision"] = -1.0;
  EXPECT_EQ(formatJson(doc, 2),
            "{\n"
            "  \"topics\": {\n"
            "    \"b/x\": {\"messages\": 3, \"age_ms\": {\"median\": 1.5, \"p99\": 2.0}},\n"
            "    \"a\": {\"messages\": 1}\n"
            "  },\n"
            "  \"missing\": [],\n"
            "  \"precision\": -1.0\n"
            "}");
  EXPECT_EQ(formatJson(doc, 1).find("\n    "),
            std::string::npos);                     // nothing below level 1 expanded
  EXPECT_EQ(Json::parse(formatJson(doc, 0)), doc);  // one line, the same document
}

TEST(JsonOutput, StringsAreEscapedAndBadUtf8Replaced) {
  const Json doc = {{"name", std::string("a\"b\\c\n\xff")}};
  EXPECT_EQ(formatJson(doc, 0), "{\"name\": \"a\\\"b\\\\c\\n\xef\xbf\xbd\"}");
}

TEST(JsonOutput, TimingSummaryKeys) {
  TimingSummary t;
  t.median_ms = 1.0;
  t.samples = 4;
  EXPECT_EQ(
      formatJson(toJson(t), 0),
      "{\"median_ms\": 1.0, \"p99_ms\": 0.0, \"mean_ms\": 0.0, \"max_ms\": 0.0, \"frames\": 4}");
}

TEST(JsonOutput, WritesTheFileOrThrows) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "mlmap_json_output_test.json").string();
  writeJsonFile(path, Json{{"a", 1}}, 1);
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  EXPECT_EQ(text.str(), "{\n  \"a\": 1\n}\n");
  std::filesystem::remove(path);
  EXPECT_THROW(writeJsonFile("/nonexistent-folder/x.json", Json{{"a", 1}}, 1), std::runtime_error);
}

}  // namespace
}  // namespace mlmap::eval
