// The study store's SQLite helpers, shared by its source files (study_store.cpp, trace_table.cpp): failed
// calls as exceptions in plain words, and a prepared statement that finalizes itself. Private to
// services/study.
#pragma once

#include <sqlite3.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::study {

// A failed SQLite call as an exception: failures to write (full disk, read-only file, I/O) become a
// StoreWriteError in plain words with the store's path and the system's reason; others runtime_error.
[[noreturn]] inline void throw_sqlite_error(sqlite3* db, int rc, const std::string& what) {
  const int primary = rc & 0xff;
  const char* path = sqlite3_db_filename(db, "main");
  const std::string store = path != nullptr && *path != '\0' ? path : "(unknown path)";
  const int system_errno = sqlite3_system_errno(db);
  const std::string system = system_errno != 0 ? fmt::format(" ({})", std::strerror(system_errno)) : "";
  std::string plain;
  if (primary == SQLITE_FULL) plain = "the disk is full";
  if (primary == SQLITE_READONLY) plain = "the store is read-only (no write permission on the file or its folder?)";
  if (primary == SQLITE_IOERR) plain = "the disk failed to write (full, removed or failing?)";
  if (primary == SQLITE_CANTOPEN) plain = "a file beside the store cannot be created (read-only folder?)";
  if (!plain.empty()) {
    throw StoreWriteError(fmt::format("study store {}: cannot write: {}: {}{}", store, plain, sqlite3_errmsg(db), system));
  }
  throw std::runtime_error(fmt::format("study store {}: {}: {}", store, what, sqlite3_errmsg(db)));
}

// A prepared statement that finalizes itself; bind() takes 1-based positions like SQLite.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
      throw std::runtime_error(fmt::format("study store: cannot prepare '{}': {}", sql, sqlite3_errmsg(db)));
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int i, int v) { return check(sqlite3_bind_int(stmt_, i, v)); }
  Statement& bind(int i, double v) { return check(sqlite3_bind_double(stmt_, i, v)); }
  Statement& bind(int i, const std::string& v) {
    return check(sqlite3_bind_text(stmt_, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }
  Statement& bind_int64(int i, std::int64_t v) { return check(sqlite3_bind_int64(stmt_, i, v)); }
  Statement& bind_null(int i) { return check(sqlite3_bind_null(stmt_, i)); }
  // The bytes must stay valid until the statement runs (SQLITE_STATIC: a blob of megabytes is not copied).
  Statement& bind_blob(int i, const void* data, std::size_t size) {
    return check(sqlite3_bind_blob64(stmt_, i, data, size, SQLITE_STATIC));
  }
  // True while there is a row.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw_sqlite_error(db_, rc, "step");
  }
  void run() {
    while (step()) {
    }
  }
  // Ready to bind and run again.
  void reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }
  int column_int(int i) const { return sqlite3_column_int(stmt_, i); }
  double column_double(int i) const { return sqlite3_column_double(stmt_, i); }
  bool column_is_null(int i) const { return sqlite3_column_type(stmt_, i) == SQLITE_NULL; }
  std::int64_t column_int64(int i) const { return sqlite3_column_int64(stmt_, i); }
  const void* column_blob(int i) const { return sqlite3_column_blob(stmt_, i); }
  std::size_t column_bytes(int i) const { return static_cast<std::size_t>(sqlite3_column_bytes(stmt_, i)); }
  std::string column_text(int i) const {
    const auto* t = sqlite3_column_text(stmt_, i);
    return t ? reinterpret_cast<const char*>(t) : "";
  }

 private:
  Statement& check(int rc) {
    if (rc != SQLITE_OK) throw std::runtime_error(fmt::format("study store: bind: {}", sqlite3_errmsg(db_)));
    return *this;
  }
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

}  // namespace cpgmatch::study
