// --log-json's lines (server/service_main.h): each one JSON object, whatever the message.
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "server/service_main.h"

namespace wormdrag::service {
namespace {

TEST(JsonLog, EveryLineParsesAndKeepsItsMessage) {
  std::ostringstream out;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(out);
  spdlog::logger log("test", sink);
  log.set_formatter(JsonLogFormatter("wormdrag-worker"));
  const std::string messages[] = {
      R"(event=spot_check_skipped task=t1 reason="no other live worker")",
      "event=report_retry error=\"a\\b\tc\nd\" retry_ms=5",
      std::string("event=dataset_fetched name=\xff\xfe.csv"),  // not UTF-8
  };
  for (const auto& m : messages) log.info("{}", m);
  std::istringstream lines(out.str());
  std::string line;
  for (const auto& m : messages) {
    ASSERT_TRUE(std::getline(lines, line));
    const auto j = nlohmann::json::parse(line, nullptr, false);
    ASSERT_FALSE(j.is_discarded()) << line;
    EXPECT_EQ(j.at("level"), "info");
    EXPECT_EQ(j.at("proc"), "wormdrag-worker");
    EXPECT_EQ(j.at("ts").get<std::string>().back(), 'Z');
    if (m.find('\xff') == std::string::npos)
      EXPECT_EQ(j.at("msg"), m);
    else
      EXPECT_EQ(j.at("msg").get<std::string>().rfind("event=dataset_fetched name=", 0), 0u);
  }
  EXPECT_FALSE(std::getline(lines, line)) << "one line per message";
}

}  // namespace
}  // namespace wormdrag::service
