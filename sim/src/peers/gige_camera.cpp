#include "paintlab/sim/peers/gige_camera.h"

#include <arv.h>
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <vector>

#include "paintlab/core/error.h"
#include "paintlab/core/log.h"
#include <spdlog/spdlog.h>

namespace paintlab::sim {

namespace {

constexpr const char* kCameraName = "sim camera (GigE Vision fake, 127.0.0.1)";

// Registers of Aravis' fake camera (arvfakecamera.h) and ours: the fake serves every
// address below 0x10000 from its memory; BlackLevel lives in a free word at 0x8000.
constexpr std::uint32_t kRegWidth = 0x100;
constexpr std::uint32_t kRegHeight = 0x104;
constexpr std::uint32_t kRegSensorHeight = 0x118;
constexpr std::uint32_t kRegSensorWidth = 0x11c;
constexpr std::uint32_t kRegPixelFormat = 0x128;
constexpr std::uint32_t kRegBlackLevel = 0x8000;

// The formats this fake serves, those its XML lists: one value a pixel (Mono and the Bayer
// mosaics), 8 bits in one byte, 12 and 16 bits in two (little-endian).
std::optional<dev::PixelFormat> from_pfnc(std::uint32_t v) {
  const auto f = dev::pixel_format_from_pfnc(v);
  if (f && dev::channels(*f) == 1) return f;
  return std::nullopt;
}

constexpr dev::PixelFormat kServedFormats[] = {
    dev::PixelFormat::Mono8,     dev::PixelFormat::Mono12,    dev::PixelFormat::Mono16,    dev::PixelFormat::BayerRG8,
    dev::PixelFormat::BayerGR8,  dev::PixelFormat::BayerGB8,  dev::PixelFormat::BayerBG8,  dev::PixelFormat::BayerRG12,
    dev::PixelFormat::BayerGR12, dev::PixelFormat::BayerGB12, dev::PixelFormat::BayerBG12, dev::PixelFormat::BayerRG16,
    dev::PixelFormat::BayerGR16, dev::PixelFormat::BayerGB16, dev::PixelFormat::BayerBG16};

// An integer register of the fake (big-endian, 4 bytes) as GenICam XML.
std::string int_reg(const char* name, std::uint32_t address, const char* access) {
  return fmt::format(
      "  <IntReg Name=\"{}\" NameSpace=\"Custom\">\n"
      "    <Address>0x{:x}</Address>\n    <Length>4</Length>\n    <AccessMode>{}</AccessMode>\n"
      "    <pPort>Device</pPort>\n    <Sign>Unsigned</Sign>\n    <Endianess>BigEndian</Endianess>\n"
      "  </IntReg>\n",
      name, address, access);
}

std::string string_reg(const char* name, std::uint32_t address, int length) {
  return fmt::format(
      "  <StringReg Name=\"{}\" NameSpace=\"Standard\">\n"
      "    <Address>0x{:x}</Address>\n    <Length>{}</Length>\n    <AccessMode>RO</AccessMode>\n"
      "    <pPort>Device</pPort>\n  </StringReg>\n",
      name, address, length);
}

std::string integer(const char* name, const char* reg, const std::string& limits) {
  return fmt::format("  <Integer Name=\"{}\" NameSpace=\"Standard\">\n    <pValue>{}</pValue>\n{}  </Integer>\n", name,
                     reg, limits);
}

std::string float_conv(const char* name, const char* unit, const char* to, const char* from, const char* reg,
                       double min, double max) {
  return fmt::format(
      "  <Float Name=\"{0}\" NameSpace=\"Standard\">\n    <pValue>{0}Converter</pValue>\n"
      "    <Min>{4}</Min>\n    <Max>{5}</Max>\n    <Unit>{1}</Unit>\n  </Float>\n"
      "  <Converter Name=\"{0}Converter\" NameSpace=\"Custom\">\n    <FormulaTo>{2}</FormulaTo>\n"
      "    <FormulaFrom>{3}</FormulaFrom>\n    <pValue>{6}</pValue>\n  </Converter>\n",
      name, unit, to, from, min, max, reg);
}

std::string enumeration(const char* name, const std::vector<std::pair<const char*, std::uint32_t>>& entries,
                        const char* reg) {
  std::string s = fmt::format("  <Enumeration Name=\"{}\" NameSpace=\"Standard\">\n", name);
  for (const auto& [n, v] : entries)
    s += fmt::format("    <EnumEntry Name=\"{}\" NameSpace=\"Standard\">\n      <Value>{}</Value>\n    </EnumEntry>\n", n, v);
  s += fmt::format("    <pValue>{}</pValue>\n  </Enumeration>\n", reg);
  return s;
}

std::string command(const char* name, const char* reg, int value) {
  return fmt::format(
      "  <Command Name=\"{}\" NameSpace=\"Standard\">\n    <pValue>{}</pValue>\n    <CommandValue>{}</CommandValue>\n"
      "  </Command>\n",
      name, reg, value);
}

std::string trigger_reg(const char* name, std::uint32_t address, const char* access) {
  return fmt::format(
      "  <IntReg Name=\"{}\" NameSpace=\"Custom\">\n    <Address>0x{:x}</Address>\n"
      "    <pIndex Offset=\"0x20\">TriggerSelectorValue</pIndex>\n    <Length>4</Length>\n"
      "    <AccessMode>{}</AccessMode>\n    <pPort>Device</pPort>\n    <Sign>Unsigned</Sign>\n"
      "    <Endianess>BigEndian</Endianess>\n  </IntReg>\n",
      name, address, access);
}

}  // namespace

std::uint16_t analytic_pixel(const FrameRequest& r, int x, int y) {
  double span = std::max(1, r.width + r.height - 2);
  double rate = kAnalyticRateDnPerS * (0.25 + 0.75 * (x + y) / span);
  double v = r.black_level + rate * r.exposure_s * std::pow(10.0, r.gain_db / 20.0);
  double max = std::ldexp(1.0, dev::bit_depth(r.format)) - 1.0;
  return static_cast<std::uint16_t>(std::clamp(std::round(v), 0.0, max));
}

void analytic_frame(const FrameRequest& r, std::uint16_t* pixels) {
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) pixels[static_cast<std::size_t>(y) * r.width + x] = analytic_pixel(r, x, y);
}

std::string GigeCamera::genicam_xml() {
  std::string x;
  x += "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n";
  x += "<RegisterDescription ModelName=\"PaintlabSim\" VendorName=\"paintlab\" StandardNameSpace=\"None\"\n"
       "  SchemaMajorVersion=\"1\" SchemaMinorVersion=\"0\" SchemaSubMinorVersion=\"1\" MajorVersion=\"1\"\n"
       "  MinorVersion=\"0\" SubMinorVersion=\"0\" ToolTip=\"paintlab simulated measurement camera\"\n"
       "  ProductGuid=\"0\" VersionGuid=\"0\" xmlns=\"http://www.genicam.org/GenApi/Version_1_0\"\n"
       "  xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\"\n"
       "  xsi:schemaLocation=\"http://www.genicam.org/GenApi/Version_1_0 GenApiSchema.xsd\">\n";
  x += "  <Category Name=\"Root\" NameSpace=\"Standard\">\n"
       "    <pFeature>DeviceControl</pFeature>\n    <pFeature>ImageFormatControl</pFeature>\n"
       "    <pFeature>AcquisitionControl</pFeature>\n    <pFeature>AnalogControl</pFeature>\n"
       "    <pFeature>TransportLayerControl</pFeature>\n  </Category>\n";
  x += "  <Category Name=\"DeviceControl\" NameSpace=\"Standard\">\n"
       "    <pFeature>DeviceVendorName</pFeature>\n    <pFeature>DeviceModelName</pFeature>\n"
       "    <pFeature>DeviceVersion</pFeature>\n    <pFeature>DeviceID</pFeature>\n  </Category>\n";
  // GigE Vision bootstrap registers (device information).
  x += string_reg("DeviceVendorName", 0x48, 32);
  x += string_reg("DeviceModelName", 0x68, 32);
  x += string_reg("DeviceVersion", 0x88, 32);
  x += string_reg("DeviceID", 0xd8, 16);

  x += "  <Category Name=\"ImageFormatControl\" NameSpace=\"Standard\">\n"
       "    <pFeature>SensorWidth</pFeature>\n    <pFeature>SensorHeight</pFeature>\n"
       "    <pFeature>Width</pFeature>\n    <pFeature>Height</pFeature>\n    <pFeature>OffsetX</pFeature>\n"
       "    <pFeature>OffsetY</pFeature>\n    <pFeature>PixelFormat</pFeature>\n  </Category>\n";
  x += integer("SensorWidth", "SensorWidthReg", "");
  x += int_reg("SensorWidthReg", kRegSensorWidth, "RO");
  x += integer("SensorHeight", "SensorHeightReg", "");
  x += int_reg("SensorHeightReg", kRegSensorHeight, "RO");
  x += integer("Width", "WidthReg", "    <Min>1</Min>\n    <pMax>SensorWidth</pMax>\n    <Inc>1</Inc>\n");
  x += int_reg("WidthReg", kRegWidth, "RW");
  x += integer("Height", "HeightReg", "    <Min>1</Min>\n    <pMax>SensorHeight</pMax>\n    <Inc>1</Inc>\n");
  x += int_reg("HeightReg", kRegHeight, "RW");
  x += integer("OffsetX", "OffsetXReg", "    <Min>0</Min>\n    <pMax>SensorWidth</pMax>\n    <Inc>1</Inc>\n");
  x += int_reg("OffsetXReg", 0x130, "RW");
  x += integer("OffsetY", "OffsetYReg", "    <Min>0</Min>\n    <pMax>SensorHeight</pMax>\n    <Inc>1</Inc>\n");
  x += int_reg("OffsetYReg", 0x134, "RW");
  x += integer("BinningHorizontal", "BinningHorizontalReg", "    <Min>1</Min>\n    <Max>1</Max>\n");
  x += int_reg("BinningHorizontalReg", 0x108, "RW");
  x += integer("BinningVertical", "BinningVerticalReg", "    <Min>1</Min>\n    <Max>1</Max>\n");
  x += int_reg("BinningVerticalReg", 0x10c, "RW");
  std::vector<std::pair<const char*, std::uint32_t>> formats;
  for (dev::PixelFormat f : kServedFormats) formats.emplace_back(dev::to_string(f), dev::pfnc_code(f));
  x += enumeration("PixelFormat", formats, "PixelFormatReg");
  x += int_reg("PixelFormatReg", kRegPixelFormat, "RW");

  x += "  <Category Name=\"AcquisitionControl\" NameSpace=\"Standard\">\n"
       "    <pFeature>AcquisitionMode</pFeature>\n    <pFeature>AcquisitionStart</pFeature>\n"
       "    <pFeature>AcquisitionStop</pFeature>\n    <pFeature>TriggerSelector</pFeature>\n"
       "    <pFeature>TriggerMode</pFeature>\n    <pFeature>TriggerSource</pFeature>\n"
       "    <pFeature>TriggerActivation</pFeature>\n    <pFeature>TriggerSoftware</pFeature>\n"
       "    <pFeature>ExposureTime</pFeature>\n  </Category>\n";
  x += enumeration("AcquisitionMode", {{"Continuous", 1}, {"SingleFrame", 2}, {"MultiFrame", 3}},
                   "AcquisitionModeReg");
  x += int_reg("AcquisitionModeReg", 0x12c, "RW");
  x += command("AcquisitionStart", "AcquisitionCommandReg", 1);
  x += command("AcquisitionStop", "AcquisitionCommandReg", 0);
  x += int_reg("AcquisitionCommandReg", 0x124, "WO");
  x += "  <Float Name=\"AcquisitionFrameRate\" NameSpace=\"Standard\">\n"
       "    <pValue>AcquisitionFrameRateConverter</pValue>\n    <Unit>Hz</Unit>\n  </Float>\n"
       "  <Converter Name=\"AcquisitionFrameRateConverter\" NameSpace=\"Custom\">\n"
       "    <FormulaTo>(1000000 / FROM)</FormulaTo>\n    <FormulaFrom>(1000000 / TO)</FormulaFrom>\n"
       "    <pValue>AcquisitionFramePeriod</pValue>\n  </Converter>\n";
  x += integer("AcquisitionFramePeriod", "AcquisitionFramePeriodReg", "    <Min>1000</Min>\n    <Max>10000000</Max>\n");
  x += int_reg("AcquisitionFramePeriodReg", 0x138, "RW");
  x += "  <Enumeration Name=\"TriggerSelector\" NameSpace=\"Standard\">\n"
       "    <EnumEntry Name=\"FrameStart\" NameSpace=\"Standard\">\n      <Value>0</Value>\n    </EnumEntry>\n"
       "    <EnumEntry Name=\"AcquisitionStart\" NameSpace=\"Standard\">\n      <Value>1</Value>\n    </EnumEntry>\n"
       "    <pValue>TriggerSelectorValue</pValue>\n  </Enumeration>\n"
       "  <Integer Name=\"TriggerSelectorValue\" NameSpace=\"Custom\">\n    <Value>0</Value>\n  </Integer>\n";
  x += enumeration("TriggerMode", {{"Off", 0}, {"On", 1}}, "TriggerModeReg");
  x += trigger_reg("TriggerModeReg", 0x300, "RW");
  x += enumeration("TriggerSource", {{"Line0", 0}, {"Software", 1}}, "TriggerSourceReg");
  x += trigger_reg("TriggerSourceReg", 0x304, "RW");
  x += enumeration("TriggerActivation", {{"RisingEdge", 0}}, "TriggerActivationReg");
  x += trigger_reg("TriggerActivationReg", 0x308, "RW");
  x += command("TriggerSoftware", "TriggerSoftwareReg", 1);
  x += int_reg("TriggerSoftwareReg", 0x30c, "WO");
  // Exposure in us (SFNC ExposureTime); the register holds whole microseconds.
  x += float_conv("ExposureTime", "us", "FROM", "TO", "ExposureTimeReg", 10.0, 10000000.0);
  x += int_reg("ExposureTimeReg", 0x120, "RW");

  x += "  <Category Name=\"AnalogControl\" NameSpace=\"Standard\">\n"
       "    <pFeature>Gain</pFeature>\n    <pFeature>BlackLevel</pFeature>\n  </Category>\n";
  // Gain in dB (SFNC Gain); the register holds tenths of a dB.
  x += float_conv("Gain", "dB", "FROM * 10", "TO / 10", "GainReg", 0.0, 48.0);
  x += int_reg("GainReg", 0x110, "RW");
  // Black level in DN (SFNC BlackLevel).
  x += float_conv("BlackLevel", "DN", "FROM", "TO", "BlackLevelReg", 0.0, 4095.0);
  x += int_reg("BlackLevelReg", kRegBlackLevel, "RW");

  x += "  <Category Name=\"TransportLayerControl\" NameSpace=\"Standard\">\n"
       "    <pFeature>PayloadSize</pFeature>\n  </Category>\n"
       "  <IntSwissKnife Name=\"PayloadSize\" NameSpace=\"Standard\">\n"
       "    <pVariable Name=\"WIDTH\">Width</pVariable>\n    <pVariable Name=\"HEIGHT\">Height</pVariable>\n"
       "    <pVariable Name=\"PIXELFORMAT\">PixelFormat</pVariable>\n"
       "    <Formula>WIDTH * HEIGHT * ((PIXELFORMAT&gt;&gt;16)&amp;0xFF) / 8</Formula>\n  </IntSwissKnife>\n"
       "  <Integer Name=\"TLParamsLocked\">\n    <Visibility>Invisible</Visibility>\n    <Value>0</Value>\n"
       "    <Min>0</Min>\n    <Max>1</Max>\n  </Integer>\n";
  x += "  <Port Name=\"Device\" NameSpace=\"Standard\">\n  </Port>\n</RegisterDescription>\n";
  return x;
}

struct GigeCamera::Impl {
  ArvGvFakeCamera* gv = nullptr;
  ArvFakeCamera* fake = nullptr;
  std::string xml_path;
  int lock_fd = -1;  // holds the machine-wide lock of 127.0.0.1:3956 while serving

  static void on_fill(ArvBuffer* buffer, void* self, guint32 exposure_us, guint32 gain_raw, ArvPixelFormat format) {
    static_cast<GigeCamera*>(self)->fill(buffer, exposure_us, gain_raw, format);
  }
};

GigeCamera::GigeCamera(GigeCameraOptions options, Clock& clock, FrameSource source)
    : options_(std::move(options)), clock_(clock), impl_(std::make_unique<Impl>()), source_(std::move(source)) {
  if (options_.width < 1 || options_.height < 1) throw DataError("sim camera: width and height must be >= 1");
}

GigeCamera::~GigeCamera() { stop(); }

namespace {

// GigE Vision control (GVCP) has one well-known port, 3956, and two fake cameras on
// 127.0.0.1 would both bind it and answer each other's clients. One machine-wide lock file
// serialises them: a second simulated camera (another test, another `paintlab` on a sim
// rig) waits for the first to stop instead of failing in the middle of a protocol exchange.
int lock_gige_port(double timeout_s) {
  const char* path = "/tmp/paintlab-sim-gige-3956.lock";
  int fd = ::open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0666);
  if (fd < 0) return -1;  // no lock possible (read-only /tmp): serve unguarded, as before
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  bool said = false;
  while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (errno != EWOULDBLOCK && errno != EINTR) break;
    if (std::chrono::steady_clock::now() > deadline) {
      ::close(fd);
      throw DeviceError(kCameraName, fmt::format("another simulated camera held 127.0.0.1:3956 for {:.0f} s ({})", timeout_s, path),
                        true);
    }
    if (!said) {
      spdlog::info("sim camera: waiting for another simulated camera on this machine to stop (127.0.0.1:3956)");
      said = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  // A program that does not take the lock (an older paintlab, arv-fake-gv-camera) may
  // still serve the port: the fake would then start without it and never answer.
  said = false;
  while (true) {
    int probe = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(3956);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool free = probe >= 0 && ::bind(probe, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    if (probe >= 0) ::close(probe);
    if (free || probe < 0) break;
    if (std::chrono::steady_clock::now() > deadline) {
      ::close(fd);
      throw DeviceError(kCameraName, fmt::format("127.0.0.1:3956 stayed taken by another program for {:.0f} s", timeout_s), true);
    }
    if (!said) {
      spdlog::info("sim camera: 127.0.0.1:3956 is taken by another program; waiting for it to stop");
      said = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return fd;
}

}  // namespace

GigePortLock::GigePortLock(double timeout_s) : fd_(lock_gige_port(timeout_s)) {}

GigePortLock::~GigePortLock() {
  if (fd_ >= 0) ::close(fd_);
}

int GigePortLock::release() {
  const int fd = fd_;
  fd_ = -1;
  return fd;
}

void GigeCamera::start() {
  std::lock_guard lock(mutex_);
  if (impl_->gv) return;
  const int lock_fd = GigePortLock().release();
  struct Unlock {
    int fd;
    ~Unlock() {
      if (fd >= 0) ::close(fd);
    }
  } unlock{lock_fd};
  // The fake reads its XML from a file when it is created.
  char path[] = "/tmp/paintlab-sim-camera-XXXXXX.xml";
  int fd = mkstemps(path, 4);
  if (fd < 0) throw DeviceError(kCameraName, "cannot write the GenICam XML to /tmp", false);
  std::string xml = genicam_xml();
  bool ok = write(fd, xml.data(), xml.size()) == static_cast<ssize_t>(xml.size());
  close(fd);
  if (!ok) {
    unlink(path);
    throw DeviceError(kCameraName, "cannot write the GenICam XML to /tmp", false);
  }
  ArvGvFakeCamera* gv = arv_gv_fake_camera_new_full("127.0.0.1", options_.serial.c_str(), path);
  unlink(path);
  if (!gv || !arv_gv_fake_camera_is_running(gv)) {
    if (gv) g_object_unref(gv);
    throw DeviceError(kCameraName, "cannot serve GigE Vision on 127.0.0.1:3956 (port taken by another fake camera?)", true);
  }
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(gv);
  auto w = static_cast<std::uint32_t>(options_.width), h = static_cast<std::uint32_t>(options_.height);
  arv_fake_camera_write_register(fake, kRegSensorWidth, w);
  arv_fake_camera_write_register(fake, kRegSensorHeight, h);
  arv_fake_camera_write_register(fake, kRegWidth, w);
  arv_fake_camera_write_register(fake, kRegHeight, h);
  arv_fake_camera_write_register(fake, kRegPixelFormat, dev::pfnc_code(options_.format));
  arv_fake_camera_write_register(fake, kRegBlackLevel, static_cast<std::uint32_t>(std::lround(options_.black_level)));
  // Bootstrap device information (the fake's defaults say "Aravis", "Fake").
  auto put_string = [&](std::uint32_t address, std::size_t length, const std::string& text) {
    std::vector<char> b(length, '\0');
    std::copy_n(text.begin(), std::min(text.size(), length - 1), b.begin());
    arv_fake_camera_write_memory(fake, address, static_cast<std::uint32_t>(length), b.data());
  };
  put_string(0x48, 32, "paintlab");
  put_string(0x68, 32, "PaintlabSim");
  arv_fake_camera_set_fill_pattern(fake, &Impl::on_fill, this);
  // In trigger mode the fake polls for a trigger at this rate (default 25 Hz: up to 40 ms
  // per frame of pure waiting).
  arv_fake_camera_set_trigger_frequency(fake, 1000.0);
  impl_->gv = gv;
  impl_->fake = fake;
  impl_->lock_fd = lock_fd;
  unlock.fd = -1;
}

void GigeCamera::stop() {
  ArvGvFakeCamera* gv = nullptr;
  {
    std::lock_guard lock(mutex_);
    gv = impl_->gv;
    impl_->gv = nullptr;
    impl_->fake = nullptr;
  }
  // Unref joins the fake's threads (which may be in fill(): mutex_ must be free).
  if (gv) g_object_unref(gv);
  std::lock_guard lock(mutex_);
  if (impl_->lock_fd >= 0 && !impl_->gv) {
    ::close(impl_->lock_fd);  // the port is free: the next simulated camera may serve
    impl_->lock_fd = -1;
  }
}

bool GigeCamera::running() const {
  std::lock_guard lock(mutex_);
  return impl_->gv != nullptr;
}

void GigeCamera::set_faults(const CameraFaults& f) {
  std::lock_guard lock(mutex_);
  faults_ = f;
}

void GigeCamera::set_source(FrameSource source) {
  std::lock_guard lock(mutex_);
  source_ = std::move(source);
}

void GigeCamera::fill(void* vbuffer, std::uint32_t exposure_us, std::uint32_t gain_raw, std::uint32_t format) {
  auto* buffer = static_cast<ArvBuffer*>(vbuffer);
  FrameSource source;
  FrameRequest r;
  std::size_t payload = 0;
  bool damage = false;
  ArvGvFakeCamera* gv = nullptr;
  {
    std::lock_guard lock(mutex_);
    if (!impl_->fake) return;
    std::uint32_t w = 0, h = 0, black = 0;
    arv_fake_camera_read_register(impl_->fake, kRegWidth, &w);
    arv_fake_camera_read_register(impl_->fake, kRegHeight, &h);
    arv_fake_camera_read_register(impl_->fake, kRegBlackLevel, &black);
    auto f = from_pfnc(format);
    if (!f) return;
    r.exposure_s = exposure_us * 1e-6;
    r.gain_db = gain_raw * 0.1;
    r.black_level = black;
    r.format = *f;
    r.width = static_cast<int>(w);
    r.height = static_cast<int>(h);
    r.index = frames_.load();
    payload = arv_fake_camera_get_payload(impl_->fake);
    source = source_;
    gv = impl_->gv;
    if (faults_.incomplete_frames > 0) {
      --faults_.incomplete_frames;
      damage = true;
    }
  }
  // Packet loss for this frame only (the fake drops GVSP packets at this ratio; it never
  // answers resend requests, so the frame arrives incomplete).
  g_object_set(gv, "gvsp-lost-ratio", damage ? 0.5 : 0.0, nullptr);
  // The fake allocated the buffer for its current payload (arv_buffer_get_data reports the
  // received size, 0 while filling).
  std::size_t size = 0;
  auto* data = static_cast<std::uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
  std::size_t n = static_cast<std::size_t>(r.width) * r.height;
  std::size_t bpp = dev::bit_depth(r.format) > 8 ? 2 : 1;
  if (!data || std::max(size, payload) < n * bpp) return;
  std::vector<std::uint16_t> px(n, 0);
  if (source) source(r, px.data());
  if (bpp == 1) {
    for (std::size_t i = 0; i < n; ++i) data[i] = static_cast<std::uint8_t>(std::min<std::uint16_t>(px[i], 255));
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      data[2 * i] = static_cast<std::uint8_t>(px[i] & 0xFF);
      data[2 * i + 1] = static_cast<std::uint8_t>(px[i] >> 8);
    }
  }
  ++frames_;
  // The exposure and the readout take their time on the sim clock.
  clock_.sleep_s(r.exposure_s + options_.readout_s);
}

}  // namespace paintlab::sim
