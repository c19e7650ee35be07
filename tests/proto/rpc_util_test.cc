#include "proto/rpc_util.h"

#include <cstdlib>
#include <fstream>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

TEST(RpcUtil, LoopbackAddressesAreToldFromExposedOnes) {
  for (const char* a : {"127.0.0.1:50051", "127.1.2.3:1", "localhost:80", "[::1]:50051"})
    EXPECT_TRUE(rpc::IsLoopbackAddress(a)) << a;
  for (const char* a : {"0.0.0.0:50051", "[::]:50051", "10.0.0.5:50051", "coordinator.lab:50051", "128.0.0.1:1"})
    EXPECT_FALSE(rpc::IsLoopbackAddress(a)) << a;
}

TEST(RpcUtil, TokenComesFromTheFileThenTheFlagThenTheEnvironment) {
  const std::string file = testing::TempDir() + "/rpc_util_token";
  std::ofstream(file) << "\n  abc123 \n";
  setenv(rpc::kTokenEnv, "from-env", 1);
  EXPECT_EQ(*rpc::ResolveToken(file, "from-flag"), "abc123");
  EXPECT_EQ(*rpc::ResolveToken("", "from-flag"), "from-flag");
  EXPECT_EQ(*rpc::ResolveToken("", ""), "from-env");
  unsetenv(rpc::kTokenEnv);
  EXPECT_EQ(*rpc::ResolveToken("", ""), "");
  std::ofstream(file, std::ios::trunc) << " \n";
  auto empty = rpc::ResolveToken(file, "");
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.status().message().find(file), std::string::npos);
  EXPECT_FALSE(rpc::ResolveToken(file + ".absent", "").ok());
}

}  // namespace
}  // namespace wormdrag
