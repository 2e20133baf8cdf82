// How both clients count and end sessions, through their C ABI (the
// monitor's identity tests and the test bed's scenario 60 run them end to end).
#include "contego/session_room.h"

#include <gtest/gtest.h>

namespace {

constexpr uintptr_t kMine = 100, kA = 200, kB = 300, kC = 400;

TEST(SessionRoom, AUnitsSessionsCountOnce) {
  contego_session_room r{};
  contego_room_start(&r, kMine, 2);
  EXPECT_EQ(contego_room_count(&r, kA), 1);
  EXPECT_EQ(contego_room_count(&r, kA), 1);
  EXPECT_EQ(contego_room_left(&r), 1);
  EXPECT_EQ(contego_room_count(&r, kB), 1);
  EXPECT_EQ(contego_room_left(&r), 0);  // two other units live: no room
}

TEST(SessionRoom, TheCallersOwnUnitHasRoomWhateverTheCount) {
  contego_session_room r{};
  contego_room_start(&r, kMine, 1);
  EXPECT_EQ(contego_room_count(&r, kA), 1);
  EXPECT_EQ(contego_room_left(&r), 0);
  EXPECT_EQ(contego_room_count(&r, kMine), 0);  // the answer is known
  EXPECT_EQ(contego_room_left(&r), 1);
  EXPECT_EQ(contego_room_count(&r, kB), 0);
}

TEST(SessionRoom, NoSessionLiveLeavesRoomAndTheCapIsTheMostAPolicyGives) {
  contego_session_room r{};
  contego_room_start(&r, kMine, 1);
  EXPECT_EQ(contego_room_left(&r), 1);
  contego_room_start(&r, kMine, 1000);
  EXPECT_EQ(r.allowed, uint32_t{CONTEGO_ROOM_UNITS});
  for (uintptr_t u = 1; u <= CONTEGO_ROOM_UNITS; ++u) EXPECT_EQ(contego_room_count(&r, kC + u), 1);
  EXPECT_EQ(contego_room_left(&r), 0);
}

TEST(SessionRoom, AProcessInALedGroupIsThatGroupsUnit) {
  EXPECT_EQ(contego_session_unit(kA, kB, 1), kB);  // a script's i2cset
  EXPECT_EQ(contego_session_unit(kA, kA, 1), kA);  // the leader itself
  EXPECT_EQ(contego_session_unit(kA, kB, 0), kA);  // the leader is gone
  EXPECT_EQ(contego_session_unit(kA, 0, 1), kA);   // no group (init's)
}

TEST(SessionRoom, OnlyACleanExitUnderALivingLeaderHandsTheSessionOn) {
  EXPECT_EQ(contego_session_hands_to_leader(0, kA, kB, 1), 1);
  EXPECT_EQ(contego_session_hands_to_leader(1 << 8, kA, kB, 1), 0);  // exit(1)
  EXPECT_EQ(contego_session_hands_to_leader(9, kA, kB, 1), 0);       // SIGKILL
  EXPECT_EQ(contego_session_hands_to_leader(0, kA, kA, 1), 0);       // it was the leader
  EXPECT_EQ(contego_session_hands_to_leader(0, kA, kB, 0), 0);       // the leader is gone
  EXPECT_EQ(contego_session_hands_to_leader(0, kA, 0, 1), 0);        // no group
}

}  // namespace
