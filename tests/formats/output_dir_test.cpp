// Atomic output directories: files appear only at commit; failures leave nothing behind.
#include "formats/output_dir.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <stdexcept>

#include "api/test_support.h"
#include "small_disk.h"

namespace fragsim::formats {
namespace {

namespace fs = std::filesystem;

class OutputDirTest : public ::testing::Test {
 protected:
  void SetUp() override { root_ = api::testing::fresh_test_dir("fragsim_outdir_test_"); }
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
  EXPECT_EQ(api::testing::read_text(dir / "summary.json"), "{}\n");
  EXPECT_EQ(api::testing::read_text(dir / "results.h5"), "data");
}

// A process killed while staging leaves its temporaries. A restarted one may get the same process
// id (always PID 1 in a container): the names of its temporaries must not collide with them
// (they were ".<name>.tmp.<pid>.<n>" and created exclusively, so the rerun failed).
TEST_F(OutputDirTest, LeftoversOfAKilledRunWithTheSameProcessIdDoNotBlock) {
  const fs::path dir = root_ / "job";
  fs::create_directories(dir);
  const std::string pid = std::to_string(::getpid());
  for (const std::string& name :
       {".summary.json.tmp." + pid + ".0", ".results.h5.tmp." + pid + ".1",
        ".summary.json.tmp." + pid + ".1", ".results.h5.tmp." + pid + ".0"})
    std::ofstream(dir / name) << "partial";
  OutputDir out(dir);
  out.stage_text("summary.json", "{}\n");
  out.stage("results.h5", [](const fs::path& p) {
    const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);  // as HDF5 does
    if (fd < 0) throw std::runtime_error("cannot create " + p.string());
    ::close(fd);
  });
  out.commit();
  EXPECT_TRUE(fs::exists(dir / "summary.json"));
  EXPECT_TRUE(fs::exists(dir / "results.h5"));
}

// The leftovers are cleared where no other writer can be at work: only hidden ".<name>.tmp.*"
// files, nothing else.
TEST_F(OutputDirTest, StaleTemporariesAreRemovedAndNothingElse) {
  const fs::path dir = root_ / "job";
  fs::create_directories(dir / ".sub.tmp.dir");
  for (const char* name :
       {".summary.json.tmp.1.0", ".results.h5.tmp.9f3a.2", "summary.json", ".hidden", "x.tmp.1"})
    std::ofstream(dir / name) << "x";
  EXPECT_EQ(remove_stale_temporaries(dir), 2u);
  EXPECT_EQ(entries(dir),
            (std::vector<std::string>{".hidden", ".sub.tmp.dir", "summary.json", "x.tmp.1"}));
  EXPECT_EQ(remove_stale_temporaries(root_ / "missing"), 0u);  // no directory: nothing, no throw
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
  EXPECT_EQ(api::testing::read_text(dir / "summary.json"), "old");
  {
    OutputDir out(dir);
    out.stage_text("summary.json", "new");
    out.commit();
  }
  EXPECT_EQ(api::testing::read_text(dir / "summary.json"), "new");
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

// A full disk is a StorageFullError naming the file and the bytes, found before anything is
// written (the space is reserved first), and the staged name a reader knows, with no temporary
// left; once space is freed the same write succeeds.
TEST_F(OutputDirTest, AFullDiskIsStorageFullWithThePathAndTheBytes) {
  std::string why;
  const auto disk = fragsim::testing::SmallDisk::make(root_ / "disk", 1 << 20, &why);
  if (!disk) GTEST_SKIP() << "no small file system here: " << why;
  const std::string two_mib(2 << 20, 'x');
  const fs::path file = root_ / "disk" / "big";
  try {
    write_new_file(file, two_mib);
    FAIL() << "wrote 2 MiB on a 1 MiB file system";
  } catch (const StorageFullError& e) {
    EXPECT_EQ(e.path(), file);
    EXPECT_EQ(e.error(), ENOSPC);
    EXPECT_EQ(e.bytes_needed(), 2 << 20);
    EXPECT_NE(std::string(e.what()).find("No space left on device writing " + file.string() +
                                         " (2097152 bytes needed)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(file));

  const fs::path dir = root_ / "disk" / "out";
  {
    OutputDir out(dir);
    out.stage_text("summary.json", "{}\n");
    try {
      out.stage_text("results.h5", two_mib);
      FAIL() << "staged 2 MiB on a 1 MiB file system";
    } catch (const StorageFullError& e) {
      EXPECT_EQ(e.path(), dir / "results.h5");  // not the temporary's name
      EXPECT_EQ(e.bytes_needed(), 2 << 20);
    }
  }
  EXPECT_FALSE(fs::exists(dir));  // discarded: nothing staged remains, the new directory goes
  EXPECT_GT(disk->available(), (1 << 20) - (64 << 10));

  OutputDir again(dir);
  again.stage_text("results.h5", std::string(512 << 10, 'y'));
  again.commit();
  EXPECT_EQ(fs::file_size(dir / "results.h5"), 512u << 10);
}

}  // namespace
}  // namespace fragsim::formats
