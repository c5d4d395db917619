#include "util/status.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>

namespace simplexdb {
namespace {

TEST(Status, OkIsCheapAndPrintsOk) {
  const Status s;
  EXPECT_TRUE(s.ok());
  EXPECT_EQ(s.code(), Status::Code::kOk);
  EXPECT_EQ(s.ToString(), "OK");
  EXPECT_TRUE(s.message().empty());
}

TEST(Status, CodesAndMessages) {
  const Status c = Status::Corruption("store.sdb: block 7 checksum mismatch");
  EXPECT_FALSE(c.ok());
  EXPECT_TRUE(c.IsCorruption());
  EXPECT_FALSE(c.IsIOError());
  EXPECT_EQ(c.ToString(), "corruption: store.sdb: block 7 checksum mismatch");
  EXPECT_TRUE(Status::NotFound("x").IsNotFound());
  EXPECT_TRUE(Status::IOError("x").IsIOError());
  EXPECT_TRUE(Status::NotSupported("x").IsNotSupported());
  EXPECT_TRUE(Status::InvalidArgument("x").IsInvalidArgument());
  EXPECT_TRUE(Status::ResourceExhausted("x").IsResourceExhausted());
}

TEST(Status, CopiesAndMovesKeepTheError) {
  Status a = Status::IOError("disk");
  const Status b = a;  // copy
  EXPECT_EQ(b.ToString(), a.ToString());
  Status c = std::move(a);
  EXPECT_TRUE(c.IsIOError());
  Status d;
  d = c;
  EXPECT_EQ(d.message(), "disk");
}

Result<int> Half(int x) {
  if (x % 2 != 0) return Status::InvalidArgument(std::to_string(x) + " is odd");
  return x / 2;
}

Status Quarter(int x, int* out) {
  SDB_ASSIGN_OR_RETURN(const int h, Half(x));
  SDB_ASSIGN_OR_RETURN(*out, Half(h));
  return Status::OK();
}

TEST(Result, ValueOrError) {
  const Result<int> r = Half(8);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*r, 4);
  EXPECT_TRUE(r.status().ok());
  const Result<int> e = Half(3);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.status().ToString(), "invalid argument: 3 is odd");
}

TEST(Result, MacrosPropagate) {
  int out = 0;
  EXPECT_TRUE(Quarter(8, &out).ok());
  EXPECT_EQ(out, 2);
  EXPECT_EQ(Quarter(6, &out).message(), "3 is odd");
  EXPECT_EQ(Quarter(5, &out).message(), "5 is odd");
}

TEST(Result, HoldsMoveOnlyValues) {
  Result<std::unique_ptr<int>> r = std::make_unique<int>(7);
  ASSERT_TRUE(r.ok());
  std::unique_ptr<int> p = std::move(r).value();
  EXPECT_EQ(*p, 7);
}

}  // namespace
}  // namespace simplexdb
