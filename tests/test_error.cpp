// PIPETILE_ASSERT stays on in every build: this file is compiled with NDEBUG whatever the build
// type, as a Release build compiles the library.
#ifndef NDEBUG
#define NDEBUG
#endif

#include <pipetile/error.h>

#include <gtest/gtest.h>

#include <string>

using namespace pipetile;

TEST(Error, AssertThrowsAnInternalErrorWithNdebugDefined)
{
    int calls = 0;
    const auto invariant = [&](bool holds) {
        ++calls;
        return holds;
    };
    EXPECT_NO_THROW(PIPETILE_ASSERT(invariant(true), "never shown"));
    const int line = __LINE__ + 2;
    try {
        PIPETILE_ASSERT(invariant(false), "the test's invariant");
        FAIL() << "PIPETILE_ASSERT did not throw";
    } catch (const InternalError& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("the test's invariant"), std::string::npos) << message;
        EXPECT_NE(message.find("test_error.cpp:" + std::to_string(line)), std::string::npos) << message;
        EXPECT_NE(message.find("invariant(false)"), std::string::npos) << message;
    }
    // The condition is evaluated once per check, as an if statement would be.
    EXPECT_EQ(calls, 2);
}

TEST(Error, InternalAndUsageErrorsArePipetileErrors)
{
    EXPECT_THROW(throw InternalError("x"), Error);
    EXPECT_THROW(throw UsageError("x"), Error);
    const Error e("lower the slice spacing", {Setting::Spacing});
    ASSERT_EQ(e.settings().size(), 1u);
    EXPECT_EQ(e.settings()[0], Setting::Spacing);
}

TEST(Error, FrontEndsNameTheSettingsTheirOwnWay)
{
    const Error one("lower the spacing", {Setting::Spacing});
    EXPECT_EQ(withSettings(one, "--", ""), "lower the spacing (--spacing)");
    const UsageError two("lower the rays or the levels", {Setting::Rays, Setting::Levels});
    EXPECT_EQ(withSettings(two, "", "="), "lower the rays or the levels (rays=, levels=)");
    EXPECT_EQ(withSettings(Error("no such file"), "--", ""), "no such file");
}
