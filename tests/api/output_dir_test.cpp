// Atomic output directories: files appear only at commit; failures leave nothing behind.
#include "api/output_dir.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <stdexcept>

#include "test_support.h"

namespace fragsim::api {
namespace {

namespace fs = std::filesystem;

class OutputDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = testing::fresh_test_dir("fragsim_outdir_test_");
  }
  void TearDown() override { fs::remove_all(root_); }

  static std::vector<std::string> entries(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path root_;
};

TEST_F(OutputDirTest, FilesAppearOnlyAtCommitAndNoTemporaryRemains) {
  const fs::path dir = root_ / "out";
  OutputDir out(dir);
  EXPECT_TRUE(out.created());
  out.stage_text("summary.json", "{}\n");
  out.stage("results.h5", [](const fs::path& p) { std::ofstream(p) << "data"; });
  // Staged: only temporaries (hidden names) so far.
  for (const auto& name : entries(dir)) {
    EXPECT_EQ(name[0], '.') << name;
    EXPECT_NE(name.find(".tmp."), std::string::npos) << name;
  }
  EXPECT_FALSE(fs::exists(dir / "summary.json"));
  out.commit();
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"results.h5", "summary.json"}));
  EXPECT_EQ(testing::read_text(dir / "summary.json"), "{}\n");
  EXPECT_EQ(testing::read_text(dir / "results.h5"), "data");
}

TEST_F(OutputDirTest, WithoutCommitNothingRemainsAndTheCreatedDirectoryGoes) {
  const fs::path dir = root_ / "a" / "b" / "out";
  {
    OutputDir out(dir);
    out.stage_text("summary.json", "{}\n");
    EXPECT_TRUE(fs::exists(dir));
  }
  EXPECT_FALSE(fs::exists(root_ / "a"));  // the whole chain it created
  EXPECT_TRUE(fs::exists(root_));
}

TEST_F(OutputDirTest, AnExistingDirectoryIsKeptWithItsFiles) {
  const fs::path dir = root_ / "existing";
  fs::create_directories(dir);
  std::ofstream(dir / "notes.txt") << "mine";
  std::ofstream(dir / "summary.json") << "old";
  {
    OutputDir out(dir);
    EXPECT_FALSE(out.created());
    out.stage_text("summary.json", "new");
  }
  EXPECT_EQ(entries(dir), (std::vector<std::string>{"notes.txt", "summary.json"}));
  EXPECT_EQ(testing::read_text(dir / "summary.json"), "old");
  {
    OutputDir out(dir);
    out.stage_text("summary.json", "new");
    out.commit();
  }
  EXPECT_EQ(testing::read_text(dir / "summary.json"), "new");
}

TEST_F(OutputDirTest, AFailingWriterLeavesNoTemporary) {
  const fs::path dir = root_ / "out";
  OutputDir out(dir);
  out.stage_text("summary.json", "{}");
  EXPECT_THROW(out.stage("results.h5",
                         [](const fs::path& p) {
                           std::ofstream(p) << "partial";
                           throw std::runtime_error("disk full");
                         }),
               std::runtime_error);
  EXPECT_EQ(entries(dir).size(), 1u);  // only the summary's temporary
  out.discard();
  EXPECT_FALSE(fs::exists(dir));
}

TEST_F(OutputDirTest, AWriterThatCreatesNoFileIsAnError) {
  OutputDir out(root_ / "out");
  EXPECT_THROW(out.stage("results.h5", [](const fs::path&) {}), std::runtime_error);
}

TEST_F(OutputDirTest, RejectsAFileInThePlaceOfTheDirectory) {
  std::ofstream(root_ / "file") << "x";
  EXPECT_THROW(OutputDir(root_ / "file"), std::runtime_error);
  EXPECT_THROW(OutputDir(root_ / "file" / "sub"), std::runtime_error);
  EXPECT_EQ(entries(root_), std::vector<std::string>{"file"});
}

TEST_F(OutputDirTest, NamesMustBePlain) {
  OutputDir out(root_ / "out");
  EXPECT_THROW(out.stage_text("../escape.json", "{}"), std::invalid_argument);
  EXPECT_THROW(out.stage_text("", "{}"), std::invalid_argument);
}

}  // namespace
}  // namespace fragsim::api
