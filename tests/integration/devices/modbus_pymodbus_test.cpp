// Interoperability with an independent Modbus implementation (pymodbus, run by the system
// /usr/bin/python3): ModbusTurntable against a pymodbus server serving the same register
// map over TCP and RTU, and our simulated controller read and written by a pymodbus client.
#include <gtest/gtest.h>

#include <filesystem>

#include "paintlab/core/json.h"
#include "paintlab/devices/modbus_turntable.h"
#include "paintlab/sim/peers/turntable_server.h"
#include "process_util.h"
#include "fake_rig.h"
#include "test_util.h"

namespace paintlab {
namespace {

namespace fs = std::filesystem;
using test::NearAngleDeg;

const char* kPython = "/usr/bin/python3";

fs::path script() { return test::source_dir() / "tests/integration/devices/pymodbus_peer.py"; }

bool have_pymodbus() {
  test::Process p({kPython, "-c", "import pymodbus.server, pymodbus.client"});
  return p.wait_exit(30.0) == 0;
}

fs::path write_map(const test::TempDir& dir, const std::string& name) {
  fs::path p = dir / (name + ".json");
  test::write_text(p, dev::builtin_register_map(name).to_json().dump());
  return p;
}

class PymodbusServer : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    ASSERT_TRUE(have_pymodbus()) << "python3-pymodbus (and python3-serial-asyncio) not importable; scripts/setup.sh installs them";
  }
};

void drive(dev::ModbusTurntable& table, test::FakeClock& clock) {
  ASSERT_TRUE(table.connect());
  ASSERT_TRUE(table.move_to(42.5));
  double t0 = clock.now_s();
  auto a = table.wait_settled(10.0);
  ASSERT_TRUE(a) << a.error().what();
  EXPECT_THAT(*a, NearAngleDeg(42.5, 1e-9));
  // The pymodbus controller reports "moving" for three status reads: the driver polled.
  EXPECT_GE(clock.now_s() - t0, 3 * table.config().poll_interval_s - 1e-9);
  auto st = table.status();
  ASSERT_TRUE(st);
  EXPECT_TRUE(st->in_position);
  EXPECT_FALSE(st->moving);
  ASSERT_TRUE(table.home());
  a = table.wait_settled(10.0);
  ASSERT_TRUE(a);
  EXPECT_THAT(*a, NearAngleDeg(0.0, 1e-9));
}

TEST_P(PymodbusServer, DriverMovesTheTableOverTcp) {
  test::TempDir dir;
  int port = test::free_tcp_port();
  test::Process server({kPython, script().string(), "server", "--map", write_map(dir, GetParam()).string(), "--tcp",
                        std::to_string(port)});
  ASSERT_TRUE(server.wait_for("ready", 30.0));
  ASSERT_TRUE(test::wait_tcp(port, 15.0)) << "pymodbus server did not listen";
  test::FakeClock clock;
  dev::ModbusTurntableConfig cfg;
  cfg.map = dev::builtin_register_map(GetParam());
  cfg.scale.counts_per_deg = 100;
  cfg.port = port;
  cfg.response_timeout_s = 1.0;
  dev::ModbusTurntable table(cfg, clock);
  drive(table, clock);
  // An unmapped register is an exception reply from pymodbus too.
  dev::ModbusTurntableConfig bad = cfg;
  bad.map.encoder_position.address = 0xFFF0;
  dev::ModbusTurntable probe(bad, clock);
  auto r = probe.angle_deg();
  ASSERT_FALSE(r);
  EXPECT_FALSE(r.error().retryable());
  EXPECT_THAT(r.error().what(), ::testing::HasSubstr("register 0xFFF0 (encoder_position) read: Modbus exception 0x02"));
}

TEST_P(PymodbusServer, DriverMovesTheTableOverRtu) {
  test::TempDir dir;
  test::PtyPair pty;
  test::Process server({kPython, script().string(), "server", "--map", write_map(dir, GetParam()).string(), "--rtu",
                        pty.a});
  ASSERT_TRUE(server.wait_for("ready", 30.0));
  test::FakeClock clock;
  dev::ModbusTurntableConfig cfg;
  cfg.transport = dev::ModbusTurntableConfig::Transport::Rtu;
  cfg.serial_device = pty.b;
  cfg.parity = 'N';
  cfg.map = dev::builtin_register_map(GetParam());
  cfg.scale.counts_per_deg = 100;
  cfg.response_timeout_s = 1.0;
  cfg.retries = 5;  // the server may still be opening its end of the pty
  cfg.backoff_s = 0.2;
  dev::ModbusTurntable table(cfg, clock);
  drive(table, clock);
}

INSTANTIATE_TEST_SUITE_P(Maps, PymodbusServer, ::testing::Values("oriental-az", "leadshine-pr"));

class PymodbusClient : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override {
    ASSERT_TRUE(have_pymodbus()) << "python3-pymodbus not importable; scripts/setup.sh installs it";
  }
};

TEST_P(PymodbusClient, ReadsAndWritesTheSimulatedController) {
  bool rtu = GetParam();
  test::TempDir dir;
  sim::TurntableServerOptions o;
  o.map = dev::builtin_register_map("oriental-az");
  o.scale.counts_per_deg = 100;
  // Real time here: the Python client cannot advance a test clock. 1000 counts/s = 10 deg/s.
  sim::TurntableServer server(o, system_clock());
  std::vector<std::string> args = {kPython, script().string(), "client", "--map", write_map(dir, "oriental-az").string(),
                                   "--target-counts", "1500", "--speed", "10000", "--accel", "100000"};
  if (rtu) {
    args.push_back("--rtu");
    args.push_back(server.start_rtu());
  } else {
    args.push_back("--tcp");
    args.push_back(std::to_string(server.start_tcp(0)));
  }
  test::Process client(args);
  std::string out;
  auto line = client.wait_for("{", 30.0, &out);
  ASSERT_TRUE(line) << out;
  Json j = Json::parse(*line);
  ASSERT_FALSE(j.contains("error")) << *line;
  EXPECT_EQ(j["encoder"].get<int>(), 1500);
  EXPECT_TRUE(j["saw_moving"].get<bool>()) << "15 deg at 100 deg/s takes 0.16 s";
  EXPECT_EQ(j["unmapped_exception"].get<int>(), 2);
  EXPECT_NEAR(server.angle_deg(), 15.0, 1e-9);
  EXPECT_EQ(client.wait_exit(10.0), 0);
}

INSTANTIATE_TEST_SUITE_P(Transports, PymodbusClient, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? std::string("Rtu") : std::string("Tcp"); });

}  // namespace
}  // namespace paintlab
