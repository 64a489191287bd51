#pragma once
// Reading a store as an operator would, with sqlite3 itself (not Store, which upgrades it).
#include <sqlite3.h>

#include <filesystem>
#include <string>

namespace fragsim::server::testing {

// meta.schema_version of the store at `path` ("" when it has none or cannot be read).
inline std::string meta_schema_version(const std::filesystem::path& path) {
  sqlite3* db = nullptr;
  std::string v;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db, "SELECT value FROM meta WHERE key = 'schema_version'", -1, &st, nullptr);
    if (st != nullptr && sqlite3_step(st) == SQLITE_ROW)
      v = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
  }
  sqlite3_close(db);
  return v;
}

}  // namespace fragsim::server::testing
