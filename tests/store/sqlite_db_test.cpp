#include "store/sqlite_db.h"

#include <gtest/gtest.h>
#include "support/test_paths.h"
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace pd::sqlite {
namespace {

namespace fs = std::filesystem;

template <typename F>
std::string store_error_of(F&& f) {
  try {
    f();
  } catch (const StoreError& e) {
    return e.what();
  }
  return "(no StoreError thrown)";
}

class SqliteDbTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir("sqlite_db");
    path_ = (dir_ / "test.sqlite").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  static int64_t count_rows(Db& db, const std::string& table_sql) {
    Statement st(db, table_sql);
    EXPECT_TRUE(st.step());
    return st.column_int64(0);
  }

  fs::path dir_;
  std::string path_;
};

TEST_F(SqliteDbTest, OpenFailureNamesTheFile) {
  const std::string missing = (dir_ / "no_such_folder" / "farm.sqlite").string();
  const std::string message = store_error_of([&] { Db db(missing); });
  EXPECT_EQ(message.rfind(missing + ": open: ", 0), 0u) << message;
  EXPECT_NE(message.find("unable to open"), std::string::npos) << message;
}

TEST_F(SqliteDbTest, SyntaxErrorNamesTheFileTheOperationAndSqlite) {
  Db db(path_);
  const std::string message = store_error_of([&] { Statement st(db, "SELEC 1", "probe"); });
  EXPECT_EQ(message.rfind(path_ + ": probe: ", 0), 0u) << message;
  EXPECT_NE(message.find("syntax error"), std::string::npos) << message;
  // exec names the operation it was given the same way.
  EXPECT_EQ(store_error_of([&] { db.exec("CREATE TABLE", "make"); }).rfind(path_ + ": make: ", 0), 0u);
}

TEST_F(SqliteDbTest, FileThatIsNotADatabaseIsReportedOnFirstUse) {
  std::ofstream(path_) << std::string(4096, 'x');
  Db db(path_);
  EXPECT_EQ(store_error_of([&] { db.exec("SELECT * FROM sqlite_master", "probe"); }),
            path_ + ": probe: file is not a database");
}

TEST_F(SqliteDbTest, LockedDatabaseNamesTheTransaction) {
  Db a(path_), b(path_);
  a.exec("CREATE TABLE t(x)");
  a.busy_timeout(0);
  b.busy_timeout(0);
  Transaction hold(a, Transaction::Mode::immediate, "holder");
  EXPECT_EQ(store_error_of([&] { Transaction tx(b, Transaction::Mode::immediate, "claim_next"); }),
            path_ + ": claim_next: database is locked");
  // The failed BEGIN restored the connection's label.
  EXPECT_EQ(b.label(), "sqlite");
}

TEST_F(SqliteDbTest, ErrorInsideATransactionCarriesItsLabel) {
  Db db(path_);
  db.exec("CREATE TABLE t(x INTEGER PRIMARY KEY)");
  Transaction tx(db, Transaction::Mode::deferred, "add_job");
  Statement insert(db, "INSERT INTO t(x) VALUES(?1)");
  insert.bind(1, 7).run();
  insert.reset();
  insert.bind(1, 7);
  const std::string message = store_error_of([&] { insert.run(); });
  EXPECT_EQ(message.rfind(path_ + ": add_job: ", 0), 0u) << message;
  EXPECT_NE(message.find("UNIQUE constraint failed"), std::string::npos) << message;
}

TEST_F(SqliteDbTest, TransactionRolledBackOnExceptionLeavesNothing) {
  Db db(path_);
  db.exec("CREATE TABLE t(x)");
  EXPECT_THROW(
      {
        Transaction tx(db, Transaction::Mode::immediate, "fill");
        Statement insert(db, "INSERT INTO t(x) VALUES(?1)");
        for (int i = 0; i < 3; ++i) {
          insert.bind(1, i).run();
          insert.reset();
        }
        throw std::runtime_error("stop before commit");
      },
      std::runtime_error);
  EXPECT_EQ(count_rows(db, "SELECT COUNT(*) FROM t"), 0);
  EXPECT_EQ(db.label(), "sqlite");
  // A second connection sees nothing either, and the write lock was released.
  Db other(path_);
  other.busy_timeout(0);
  EXPECT_EQ(count_rows(other, "SELECT COUNT(*) FROM t"), 0);
  EXPECT_NO_THROW(other.exec("INSERT INTO t(x) VALUES(1)"));
}

TEST_F(SqliteDbTest, CommittedTransactionIsVisibleToAnotherConnection) {
  Db db(path_);
  db.exec("CREATE TABLE t(x)");
  {
    Transaction tx(db, Transaction::Mode::immediate, "fill");
    Statement(db, "INSERT INTO t(x) VALUES(1)").run();
    tx.commit();
    EXPECT_THROW(tx.commit(), StoreError);  // a second commit is a programming error, not silent
  }
  Db other(path_);
  EXPECT_EQ(count_rows(other, "SELECT COUNT(*) FROM t"), 1);
}

TEST_F(SqliteDbTest, StatementBindsAndReadsEveryTypeIncludingNull) {
  Db db(path_);
  db.exec("CREATE TABLE t(i64, i, d, s, n, od, on_, oi, oin)");
  const int64_t big = -(int64_t{1} << 53) - 12345;
  const double third = 1.0 / 3.0;
  const std::string text("caf\xc3\xa9 \0 tail", 12);  // UTF-8 and an embedded NUL survive
  Statement insert(db, "INSERT INTO t VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)");
  insert.bind(1, big).bind(2, -7).bind(3, third).bind(4, text).bind(5, nullptr);
  insert.bind(6, std::optional<double>(2.5e9)).bind(7, std::optional<double>());
  insert.bind(8, std::optional<int64_t>(42)).bind(9, std::optional<int64_t>()).run();

  Statement read(db, "SELECT i64, i, d, s, n, od, on_, oi, oin FROM t");
  ASSERT_TRUE(read.step());
  EXPECT_EQ(read.columns(), 9);
  EXPECT_EQ(read.column_int64(0), big);
  EXPECT_EQ(read.column_int(1), -7);
  EXPECT_EQ(read.column_double(2), third);  // bit for bit
  EXPECT_EQ(read.column_double(1), -7.0);   // an integer reads as a double too
  EXPECT_EQ(read.column_text(3), text);
  EXPECT_TRUE(read.is_null(4));
  EXPECT_FALSE(read.is_null(3));
  EXPECT_EQ(read.column_optional_double(5), std::optional<double>(2.5e9));
  EXPECT_EQ(read.column_optional_double(6), std::nullopt);
  EXPECT_EQ(read.column_optional_int64(7), std::optional<int64_t>(42));
  EXPECT_EQ(read.column_optional_int64(8), std::nullopt);
  EXPECT_FALSE(read.step());
}

TEST_F(SqliteDbTest, ReadingAColumnAsTheWrongTypeNamesTheColumn) {
  Db db(path_);
  Statement st(db, "SELECT NULL AS kappa, 'x' AS name, 3000000000 AS big", "probe");
  ASSERT_TRUE(st.step());
  EXPECT_EQ(store_error_of([&] { st.column_text(0); }), path_ + ": probe: column 'kappa' holds null, expected text");
  EXPECT_EQ(store_error_of([&] { st.column_int64(1); }), path_ + ": probe: column 'name' holds text, expected integer");
  EXPECT_EQ(store_error_of([&] { st.column_int(2); }), path_ + ": probe: column 'big': 3000000000 does not fit an int");
  EXPECT_EQ(st.column_int64(2), 3000000000);
}

TEST_F(SqliteDbTest, ResetRunsAStatementAgainWithNewBindings) {
  Db db(path_);
  Statement st(db, "SELECT ?1 + ?2");
  ASSERT_TRUE(st.bind_all(2, 3).step());
  EXPECT_EQ(st.column_int(0), 5);
  st.reset();
  ASSERT_TRUE(st.bind_all(int64_t{40}, 2.5).step());
  EXPECT_EQ(st.column_double(0), 42.5);
  st.reset();
  ASSERT_TRUE(st.step());  // bindings were cleared: NULL + NULL
  EXPECT_TRUE(st.is_null(0));
}

TEST_F(SqliteDbTest, BadParameterIndexAndUnexpectedRowAreErrors) {
  Db db(path_);
  Statement st(db, "SELECT ?1", "probe");
  const std::string message = store_error_of([&] { st.bind(2, 1); });
  EXPECT_EQ(message.rfind(path_ + ": probe: parameter 2: ", 0), 0u) << message;
  EXPECT_EQ(store_error_of([&] { st.bind(1, 1).run(); }), path_ + ": probe: statement returned a row");
}

}  // namespace
}  // namespace pd::sqlite
