// The control protocol apart from the socket (control_protocol.hpp): every line gets one reply
// object, bad ones an error naming what is wrong; nothing throws. The fuzz harness
// (tests/fuzz/control_protocol_fuzz.cpp) checks the same on generated lines.
#include <gtest/gtest.h>

#include <string>

#include "hmdnode/firmware_host/control_protocol.hpp"

using hmdnode::answer_control_line;
using hmdnode::ControlCommand;
using hmdnode::parse_control_command;
using Kind = ControlCommand::Kind;

namespace {

nlohmann::json through_parser(const std::string& line) {
    return answer_control_line(line, [](const nlohmann::json& c) -> nlohmann::json {
        auto cmd = parse_control_command(c);
        if (!cmd.ok()) return {{"ok", false}, {"error", cmd.error().message}};
        return {{"ok", true}, {"kind", int(cmd->kind)}};
    });
}

}  // namespace

TEST(ControlProtocol, KnownCommandsParse) {
    EXPECT_EQ(through_parser(R"({"cmd":"status"})")["kind"], int(Kind::status));
    EXPECT_EQ(through_parser(R"({"cmd":"metrics"})")["kind"], int(Kind::metrics));
    EXPECT_EQ(through_parser(R"({"cmd":"pause"})")["kind"], int(Kind::pause));
    EXPECT_EQ(through_parser(R"({"cmd":"resume"})")["kind"], int(Kind::resume));
    auto p = parse_control_command(
        nlohmann::json::parse(R"({"cmd":"set","key":"predict","value":false})"));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p->kind, Kind::set_predict);
    EXPECT_FALSE(p->predict);
    p = parse_control_command(
        nlohmann::json::parse(R"({"cmd":"set","key":"lod_tolerance_px","value":2.5})"));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p->kind, Kind::set_lod_tolerance_px);
    EXPECT_DOUBLE_EQ(p->lod_tolerance_px, 2.5);
    EXPECT_EQ(through_parser(R"({"cmd":"recentre"})")["kind"], int(Kind::recentre));
    p = parse_control_command(nlohmann::json::parse(R"({"cmd":"load-scene","path":"a.glb"})"));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p->kind, Kind::load_scene);
    EXPECT_EQ(p->path, "a.glb");
    p = parse_control_command(nlohmann::json::parse(R"({"cmd":"set","key":"warp","value":false})"));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p->kind, Kind::set_warp);
    EXPECT_FALSE(p->warp);
    p = parse_control_command(
        nlohmann::json::parse(R"({"cmd":"set","key":"prediction_ms","value":-7.5})"));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p->kind, Kind::set_prediction_ms);
    EXPECT_DOUBLE_EQ(p->prediction_ms, -7.5);
    p = parse_control_command(nlohmann::json::parse(R"({"cmd":"set","key":"lod_bias","value":2})"));
    ASSERT_TRUE(p.ok());
    EXPECT_EQ(p->kind, Kind::set_lod_bias);
    EXPECT_DOUBLE_EQ(p->lod_bias, 2.0);
}

TEST(ControlProtocol, BadLinesAndFieldsGetErrorRepliesNotExceptions) {
    for (const char* line : {"",
                             "not json",
                             "[1,2]",
                             "{}",
                             R"({"cmd": 7})",
                             R"({"cmd": null})",
                             "{\"cmd\": \"st",
                             R"({"cmd":"set"})",
                             R"({"cmd":"set","key":7,"value":1})",
                             R"({"cmd":"set","key":"predict","value":"yes"})",
                             R"({"cmd":"set","key":"lod_tolerance_px","value":-1})",
                             R"({"cmd":"set","key":"lod_tolerance_px","value":1e400})",
                             R"({"cmd":"set","key":"lod_tolerance_px"})",
                             R"({"cmd":"recentre!"})",
                             R"({"cmd":"load-scene"})",
                             R"({"cmd":"load-scene","path":""})",
                             R"({"cmd":"load-scene","path":7})",
                             R"({"cmd":"set","key":"warp","value":1})",
                             R"({"cmd":"set","key":"prediction_ms","value":101})",
                             R"({"cmd":"set","key":"lod_bias","value":-9})",
                             R"({"cmd":"set","key":"lod_bias","value":true})",
                             "{\"cmd\":\"\xff\"}"}) {
        nlohmann::json r;
        ASSERT_NO_THROW(r = through_parser(line)) << line;
        EXPECT_EQ(r["ok"], false) << line;
        EXPECT_TRUE(r["error"].is_string()) << line;
        EXPECT_NO_THROW((void)r.dump()) << line;
    }
    EXPECT_NE(through_parser(R"({"cmd":"recentre!"})")["error"].get<std::string>().find("recentre"),
              std::string::npos);
    EXPECT_NE(through_parser(R"({"cmd":"set","key":"prediction_ms","value":101})")["error"]
                  .get<std::string>()
                  .find("between -100 and 100 ms"),
              std::string::npos);
    EXPECT_NE(through_parser(R"({"cmd":"set","key":"lod_tolerance_px","value":-1})")["error"]
                  .get<std::string>()
                  .find(">= 0"),
              std::string::npos);
}

TEST(ControlProtocol, AHandlerThatThrowsGetsAnErrorReply) {
    const nlohmann::json r =
        answer_control_line(R"({"cmd":"status"})", [](const nlohmann::json& c) {
            return nlohmann::json{{"ok", true}, {"n", c.at("missing").get<int>()}};
        });
    EXPECT_EQ(r["ok"], false);
    EXPECT_NE(r["error"].get<std::string>().find("bad command"), std::string::npos);
}
