// Text from outside on its way into names, logs and answers (issue 38,
// W1-W5): names and frame ids follow one rule, and every excerpt is one short
// line of valid UTF-8.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "relocalizer/core/outside_text.h"

using namespace relocalizer;

TEST(OutsideText, NamesAreGraphNameLikeAndBounded) {
  for (const std::string& name : std::vector<std::string>{
           "kitchen", "learned/0", "room-1.v2", "base_footprint", std::string(kMaxNameBytes, 'a')})
    EXPECT_EQ(nameError(name, "name"), "") << name;
  EXPECT_EQ(nameError("", "name"), "name is empty");
  EXPECT_EQ(nameError(std::string(10000, 'a'), "name"),
            "name '" + std::string(40, 'a') + "... (10000 bytes)' is longer than 128 bytes");
  EXPECT_EQ(nameError("a\nb", "map_frame"),
            "map_frame 'a?b' holds a character other than ASCII letters, digits and _ - . /");
  EXPECT_NE(nameError("k\xc3\xbc"
                      "che",
                      "name")
                .find("holds a character"),
            std::string::npos);
  EXPECT_NE(nameError("my room", "name").find("holds a character"), std::string::npos);
  for (const std::string name : {"/a", "a/", "a//b"})
    EXPECT_EQ(nameError(name, "name"),
              "name '" + name + "' has an empty part (a / at either end, or //)");
}

TEST(OutsideText, ExcerptsArePrintableUtf8CutAtACharacter) {
  EXPECT_EQ(textExcerpt("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80", 64),
            "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80");
  EXPECT_EQ(textExcerpt("a\nb\x1b[2J\x7f", 64), "a?b?[2J?");
  // Stray continuation, truncated sequence, overlong, surrogate, beyond U+10FFFF.
  EXPECT_EQ(textExcerpt("\x80x\xc3", 64), "?x?");
  EXPECT_EQ(textExcerpt("\xc0\xaf\xed\xa0\x80\xf4\x90\x80\x80", 64), "?????????");
  // Cut before a character that does not fit whole.
  EXPECT_EQ(textExcerpt("ab\xc3\xa9", 3), "ab... (4 bytes)");
  EXPECT_EQ(textExcerpt(std::string(65, 'a'), 64), std::string(64, 'a') + "... (65 bytes)");
}
