// ModbusTurntable (the real driver) against the simulated controller (a libmodbus server)
// over Modbus TCP on 127.0.0.1 and Modbus RTU on a socat pty pair, with the fault switches.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include "paintlab/core/error.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/sim/peers/turntable_server.h"
#include "fake_rig.h"
#include "test_util.h"

namespace paintlab {
namespace {

using dev::ModbusTurntable;
using dev::ModbusTurntableConfig;
using sim::ModbusFaults;
using sim::TurntableServer;
using test::NearAngleDeg;

double wall_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Rig {
  test::FakeClock clock;
  std::unique_ptr<TurntableServer> server;
  ModbusTurntableConfig cfg;

  explicit Rig(const std::string& map = "oriental-az", bool wrap = false, bool rtu = false) {
    sim::TurntableServerOptions o;
    o.map = dev::builtin_register_map(map);
    o.scale.counts_per_deg = 100;
    o.wrap = wrap;
    server = std::make_unique<TurntableServer>(o, clock);
    cfg.map = o.map;
    cfg.scale = o.scale;
    cfg.wrap = wrap;
    cfg.speed_deg_s = 30;
    cfg.accel_deg_s2 = 60;
    cfg.decel_deg_s2 = 60;
    cfg.response_timeout_s = 0.2;
    cfg.retries = 3;
    cfg.backoff_s = 0.01;
    if (rtu) {
      cfg.transport = ModbusTurntableConfig::Transport::Rtu;
      cfg.serial_device = server->start_rtu();
      cfg.parity = 'N';
    } else {
      cfg.port = server->start_tcp(0);
    }
  }
};

TEST(ModbusSim, MoveSettlesAtTargetInTheProfileTime) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.connect()) << "connect";
  double t0 = rig.clock.now_s();
  ASSERT_TRUE(table.move_to(90.0));
  auto settled = table.wait_settled(30.0);
  ASSERT_TRUE(settled) << settled.error().what();
  double elapsed = rig.clock.now_s() - t0;
  EXPECT_THAT(*settled, NearAngleDeg(90.0, 0.01));
  EXPECT_THAT(rig.server->angle_deg(), NearAngleDeg(90.0, 0.01));
  // 90 deg at 30 deg/s with 60 deg/s^2 ramps: 0.5 s + 2.5 s + 0.5 s = 3.5 s.
  EXPECT_NEAR(table.move_time_s(0.0, 90.0), 3.5, 1e-6);
  EXPECT_GE(elapsed, 3.5 - 1e-9);
  EXPECT_LE(elapsed, 3.5 + 2 * rig.cfg.poll_interval_s + 1e-9);
  auto st = table.status();
  ASSERT_TRUE(st);
  EXPECT_TRUE(st->in_position);
  EXPECT_FALSE(st->moving);
  EXPECT_TRUE(st->ready);
  EXPECT_EQ(st->alarm_code, 0);
}

TEST(ModbusSim, StatusShowsMotionWhileMoving) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.move_to(-45.0));
  rig.clock.sleep_s(1.0);
  auto st = table.status();
  ASSERT_TRUE(st) << st.error().what();
  EXPECT_TRUE(st->moving);
  EXPECT_FALSE(st->in_position);
  EXPECT_LT(st->angle_deg, -1.0);
  EXPECT_GT(st->angle_deg, -44.0);
  auto settled = table.wait_settled(10.0);
  ASSERT_TRUE(settled);
  EXPECT_THAT(*settled, NearAngleDeg(-45.0, 0.01));
}

TEST(ModbusSim, HomeReturnsToZeroAndReportsHomed) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.move_to(20.0));
  ASSERT_TRUE(table.wait_settled(10.0));
  ASSERT_TRUE(table.home());
  auto a = table.wait_settled(10.0);
  ASSERT_TRUE(a);
  EXPECT_THAT(*a, NearAngleDeg(0.0, 0.01));
  auto st = table.status();
  ASSERT_TRUE(st);
  EXPECT_TRUE(st->homed);
  EXPECT_TRUE(rig.server->homed());
}

TEST(ModbusSim, AnglesSnapToCounts) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.move_to(12.3456));
  auto a = table.wait_settled(10.0);
  ASSERT_TRUE(a);
  EXPECT_DOUBLE_EQ(*a, 12.35);  // 100 counts per degree
  EXPECT_DOUBLE_EQ(table.snapped_angle_deg(12.3456), 12.35);
}

TEST(ModbusSim, LimitsRejectAMoveWithoutTouchingTheTable) {
  Rig rig;
  rig.cfg.min_angle_deg = -10;
  rig.cfg.max_angle_deg = 190;
  ModbusTurntable table(rig.cfg, rig.clock);
  long before = rig.server->requests();
  auto r = table.move_to(200.0);
  ASSERT_FALSE(r);
  EXPECT_FALSE(r.error().retryable());
  EXPECT_THAT(r.error().what(), ::testing::HasSubstr("outside the limits"));
  EXPECT_EQ(rig.server->requests(), before);
  EXPECT_FALSE(table.move_to(std::nan("")));
}

TEST(ModbusSim, WrapAroundTableUsesWrapAbsoluteAndReportsModulo360) {
  Rig rig("oriental-az", /*wrap=*/true);
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.move_to(350.0));
  auto a = table.wait_settled(30.0);
  ASSERT_TRUE(a);
  EXPECT_THAT(*a, NearAngleDeg(350.0, 0.01));
  // 370 deg is 10 deg on a wrapping table; limits do not apply.
  ASSERT_TRUE(table.move_to(370.0));
  a = table.wait_settled(30.0);
  ASSERT_TRUE(a);
  EXPECT_NEAR(*a, 10.0, 0.01);
  EXPECT_NEAR(rig.server->angle_deg(), 10.0, 0.01);
  ASSERT_TRUE(table.move_to(-90.0));
  a = table.wait_settled(30.0);
  ASSERT_TRUE(a);
  EXPECT_NEAR(*a, 270.0, 0.01);
}

TEST(ModbusSim, SecondBuiltInMapWorksThroughTheSameCode) {
  Rig rig("leadshine-pr");
  rig.cfg.scale.motor_counts_per_rev = 36000;  // 100 counts/deg = 1 motor turn per table turn
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.move_to(45.0));
  rig.clock.sleep_s(0.5);
  auto st = table.status();
  ASSERT_TRUE(st);
  EXPECT_TRUE(st->moving);
  auto a = table.wait_settled(30.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_THAT(*a, NearAngleDeg(45.0, 0.01));
  ASSERT_TRUE(table.home());
  a = table.wait_settled(30.0);
  ASSERT_TRUE(a);
  EXPECT_THAT(*a, NearAngleDeg(0.0, 0.01));
}

TEST(ModbusSim, StopHaltsTheTableWhereItIs) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.move_to(90.0));
  rig.clock.sleep_s(1.5);
  ASSERT_TRUE(table.stop());
  auto a = table.wait_settled(1.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_GT(*a, 5.0);
  EXPECT_LT(*a, 60.0);
  EXPECT_FALSE(rig.server->moving());
}

TEST(ModbusSim, SettleTimeoutIsARetryableErrorNotAHang) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.move_to(180.0));  // needs 6.5 s
  double w0 = wall_s();
  auto a = table.wait_settled(1.0);
  ASSERT_FALSE(a);
  EXPECT_TRUE(a.error().retryable());
  EXPECT_THAT(a.error().what(), ::testing::HasSubstr("did not settle within 1 s"));
  EXPECT_LT(wall_s() - w0, 5.0);
}

TEST(ModbusSim, ExceptionReplyNamesRegisterAndException) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  // Illegal data address, for ever, at the target position register.
  rig.server->set_faults({.exception_code = 2, .exceptions = -1, .exception_address = 0x005C});
  auto r = table.move_to(10.0);
  ASSERT_FALSE(r);
  EXPECT_FALSE(r.error().retryable());
  std::string m = r.error().what();
  EXPECT_THAT(m, ::testing::HasSubstr("register 0x005C (target_position) write"));
  EXPECT_THAT(m, ::testing::HasSubstr("exception 0x02"));
  EXPECT_THAT(m, ::testing::HasSubstr("modbus-tcp 127.0.0.1:"));
}

TEST(ModbusSim, BusyExceptionIsRetried) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  rig.server->set_faults({.exception_code = 6, .exceptions = 2});  // server busy, twice
  auto a = table.angle_deg();
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_EQ(table.retry_count(), 2);
}

TEST(ModbusSim, TimeoutsAreRetriedWithBackoff) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.connect());
  rig.server->set_faults({.timeouts = 2});
  double v0 = rig.clock.now_s();
  auto a = table.angle_deg();
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_EQ(table.retry_count(), 2);
  // Backoff 10 ms then 20 ms on the driver's clock.
  EXPECT_NEAR(rig.clock.now_s() - v0, 0.03, 1e-9);
  EXPECT_EQ(rig.server->faulted_requests(), 2);
}

TEST(ModbusSim, PersistentTimeoutFailsRetryableWithinBoundedTime) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  rig.server->set_faults({.timeouts = -1});
  double w0 = wall_s();
  auto a = table.angle_deg();
  double took = wall_s() - w0;
  ASSERT_FALSE(a);
  EXPECT_TRUE(a.error().retryable());
  EXPECT_THAT(a.error().what(), ::testing::HasSubstr("no response (timeout) after 4 attempts"));
  // 4 attempts x 0.2 s response timeout.
  EXPECT_GT(took, 0.7);
  EXPECT_LT(took, 3.0);
}

TEST(ModbusSim, DroppedConnectionReconnects) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.connect());
  rig.server->set_faults({.drops = 1});
  ASSERT_TRUE(table.move_to(30.0));
  auto a = table.wait_settled(10.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_THAT(*a, NearAngleDeg(30.0, 0.01));
  EXPECT_GE(table.reconnect_count(), 1);
}

TEST(ModbusSim, ServerGoneIsRetryableConnectionError) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.connect());
  rig.server->stop();
  auto a = table.angle_deg();
  ASSERT_FALSE(a);
  EXPECT_TRUE(a.error().retryable());
}

TEST(ModbusSim, AlarmStopsMovesUntilReset) {
  Rig rig;
  ModbusTurntable table(rig.cfg, rig.clock);
  rig.server->set_faults({.alarm_code = 0x30});
  auto st = table.status();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->alarm_code, 0x30);
  EXPECT_FALSE(st->ready);
  auto r = table.move_to(10.0);
  ASSERT_FALSE(r);
  EXPECT_FALSE(r.error().retryable());
  EXPECT_THAT(r.error().what(), ::testing::HasSubstr("alarm code 48"));
  ASSERT_TRUE(table.reset_alarm());
  st = table.status();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->alarm_code, 0);
  ASSERT_TRUE(table.move_to(10.0));
  ASSERT_TRUE(table.wait_settled(10.0));
}

TEST(ModbusSim, UnknownUnitIdTimesOut) {
  Rig rig;
  rig.cfg.unit_id = 7;
  rig.cfg.retries = 0;
  ModbusTurntable table(rig.cfg, rig.clock);
  auto a = table.angle_deg();
  ASSERT_FALSE(a);
  EXPECT_TRUE(a.error().retryable());
  EXPECT_THAT(a.error().what(), ::testing::HasSubstr("timeout"));
}

TEST(ModbusSimRtu, MoveOverAPtyPair) {
  Rig rig("oriental-az", false, /*rtu=*/true);
  ASSERT_THAT(rig.cfg.serial_device, ::testing::StartsWith("/dev/pts/"));
  ModbusTurntable table(rig.cfg, rig.clock);
  ASSERT_TRUE(table.connect());
  EXPECT_THAT(table.id(), ::testing::HasSubstr("modbus-rtu /dev/pts/"));
  ASSERT_TRUE(table.move_to(33.0));
  auto a = table.wait_settled(10.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_THAT(*a, NearAngleDeg(33.0, 0.01));
}

TEST(ModbusSimRtu, ExceptionAndTimeoutOverRtu) {
  Rig rig("oriental-az", false, /*rtu=*/true);
  ModbusTurntable table(rig.cfg, rig.clock);
  ModbusFaults f;
  f.timeouts = 1;
  rig.server->set_faults(f);
  auto a = table.angle_deg();
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_EQ(table.retry_count(), 1);
  f = {};
  f.exception_code = 3;
  f.exceptions = 1;
  rig.server->set_faults(f);
  a = table.angle_deg();
  ASSERT_FALSE(a);
  EXPECT_THAT(a.error().what(), ::testing::HasSubstr("register 0x0120 (encoder_position) read: Modbus exception 0x03"));
}

}  // namespace
}  // namespace paintlab
