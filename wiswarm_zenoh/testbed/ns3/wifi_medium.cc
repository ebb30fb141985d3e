// The WiFi medium of the testbed: one 2.4 GHz 802.11 channel in ns-3, node 0 an access
// point, nodes 1..N stations, each node's device joined to a tap inside a Linux network
// namespace, in real time under a hard limit on lag (or, with --taps=0 and
// the paper's workloads generated inside, as a plain simulation at any speed, for checking
// our own 802.11 model against it).
//
// Why not ns-3's TapBridge: in UseLocal mode it rewrites the WiFi device's MAC address
// from the first frame it reads, after the station has associated under another address;
// the access point then drops that station's frames (not associated), or keeps some of
// them (a MAC split between WifiMac and its FrameExchangeManager), and its tap creator
// is looked for at Debian's build path. Here the tap in each namespace carries its ns-3
// device's own MAC address, so no address is ever
// rewritten: the scenario prints its devices' addresses, the caller gives each tap its
// node's address and answers with a line on stdin, and the scenario opens the taps
// itself (setns + TUNSETIFF).
//
// Output: on stdout {"event":"addresses","macs":[...]} (real time: then the scenario
// waits for a line on stdin) and {"event":"ready"}; then JSON lines in --statsFile
// (stdout without one): {"event":"stats",...} every --statsPeriod seconds, and once at
// the end. A lag beyond --hardLimitMs ends the run
// with exit status 3 after a {"event":"lag-exceeded"} line (ns-3's own HardLimit mode
// aborts too). SIGTERM or SIGINT end the run cleanly (final stats, status 0).
//
// Commands, in real time, one a line on stdin after "ready" (each answered by one JSON
// line on stdout, once it took effect in the simulation):
//   rate <node> <WifiMode>  station <node>'s data rate from now on (a robot flying away:
//                           its frames to the AP slower; the AP's to it, and control
//                           frames, unchanged) -> {"event":"rate","node":..,"data_mode":..}
// A bad command is answered {"event":"error","message":...} and changes nothing.
#include "ns3/ap-wifi-mac.h"
#include "ns3/core-module.h"
#include "ns3/fd-reader.h"
#include "ns3/mobility-module.h"
#include "ns3/network-module.h"
#include "ns3/realtime-simulator-impl.h"
#include "ns3/sta-wifi-mac.h"
#include "ns3/wifi-module.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <iostream>
#include <linux/if.h>
#include <linux/if_tun.h>
#include <sched.h>
#include <sys/resource.h>
#include <sstream>
#include <sys/ioctl.h>
#include <unistd.h>

using namespace ns3;

namespace
{

std::atomic<bool> g_stop{false};

void
OnSignal(int)
{
    g_stop = true;
}

std::vector<std::string>
Split(const std::string& text)
{
    std::vector<std::string> parts;
    std::stringstream in(text);
    std::string part;
    while (std::getline(in, part, ','))
    {
        if (!part.empty())
        {
            parts.push_back(part);
        }
    }
    return parts;
}

[[noreturn]] void
Fail(const std::string& what)
{
    std::cerr << "wifi_medium: " << what << std::endl;
    std::exit(2);
}

/// Opens the tap ``name`` that lives in network namespace ``ns`` (the fd outlives the switch).
int
OpenTap(const std::string& ns, const std::string& name)
{
    int home = open("/proc/self/ns/net", O_RDONLY | O_CLOEXEC);
    int target = open(("/var/run/netns/" + ns).c_str(), O_RDONLY | O_CLOEXEC);
    if (home < 0 || target < 0 || setns(target, CLONE_NEWNET) != 0)
    {
        Fail("cannot enter network namespace " + ns + ": " + std::strerror(errno));
    }
    int fd = open("/dev/net/tun", O_RDWR | O_CLOEXEC);
    struct ifreq ifr{};
    ifr.ifr_flags = IFF_TAP | IFF_NO_PI;
    std::strncpy(ifr.ifr_name, name.c_str(), IFNAMSIZ - 1);
    if (fd < 0 || ioctl(fd, TUNSETIFF, &ifr) != 0)
    {
        Fail("cannot open tap " + name + " in " + ns + ": " + std::strerror(errno));
    }
    if (setns(home, CLONE_NEWNET) != 0)
    {
        Fail(std::string("cannot return to the home namespace: ") + std::strerror(errno));
    }
    close(home);
    close(target);
    return fd;
}

/// What one node's device and tap saw.
struct Counters
{
    uint64_t fromTap = 0;      // frames read from the tap, handed to the device
    uint64_t toTap = 0;        // frames the device handed up, written to the tap
    uint64_t tapWriteErrors = 0;
    uint64_t foreignSource = 0; // frames from the tap whose source is not the device's MAC
    uint64_t macTx = 0;        // MSDUs the MAC accepted from above
    uint64_t macRx = 0;        // MSDUs the MAC handed up
    uint64_t acked = 0;        // MPDUs acknowledged
    uint64_t nacked = 0;       // transmissions whose ack never came (collisions, errors)
    uint64_t dropRetry = 0;    // MPDUs dropped after the retry limit
    uint64_t dropQueue = 0;    // MPDUs aged out of the queue (off: MaxDelay is an hour)
    uint64_t enqueued = 0;     // data MPDUs the queue took: macTx - enqueued were refused
    uint64_t phyRxDrop = 0;    // receptions the PHY failed (collisions, preamble missed)
    double txAirtime = 0;      // seconds transmitting
};

std::vector<Counters> g_counters;
std::ostream* g_stats = &std::cout;

/// What one read of an fd gives (a tap's frame, stdin's bytes); its end stops the reader.
class ChunkReader : public FdReader
{
  public:
    explicit ChunkReader(int fd)
    {
        m_fd = fd;
    }

  protected:
    Data DoRead() override
    {
        auto* buf = static_cast<uint8_t*>(std::malloc(65536));
        ssize_t len = read(m_fd, buf, 65536);
        if (len <= 0)
        {
            std::free(buf);
            return Data(nullptr, 0);
        }
        return Data(buf, len);
    }
};

/// One node's tap glued to its WiFi device: frames both ways, MAC addresses untouched.
class TapGlue : public SimpleRefCount<TapGlue>
{
  public:
    TapGlue(uint32_t index, Ptr<NetDevice> device, int fd)
        : m_index(index),
          m_nodeId(device->GetNode()->GetId()),
          m_device(device),
          m_fd(fd)
    {
        device->SetReceiveCallback(MakeCallback(&TapGlue::Ignore));
        device->SetPromiscReceiveCallback(MakeCallback(&TapGlue::FromDevice, this));
        m_reader = Create<ChunkReader>(fd);
        m_reader->Start(fd, MakeCallback(&TapGlue::FromTap, this));
    }

    void Stop()
    {
        m_reader->Stop();
    }

  private:
    static bool Ignore(Ptr<NetDevice>, Ptr<const Packet>, uint16_t, const Address&)
    {
        return true;
    }

    // The reader thread: hand the frame to the simulation at the current real time. No
    // Ptr is touched here: their reference counts are not thread-safe (a race there
    // disposed a node's PHY mid-run: "Unsupported Wi-Fi modulation class").
    void FromTap(uint8_t* buf, ssize_t len)
    {
        Simulator::ScheduleWithContext(m_nodeId,
                                       Seconds(0),
                                       MakeEvent(&TapGlue::Send, this, buf, len));
    }

    void Send(uint8_t* buf, ssize_t len)
    {
        Counters& c = g_counters[m_index];
        if (len < 14)
        {
            std::free(buf);
            return;
        }
        Mac48Address dst;
        Mac48Address src;
        dst.CopyFrom(buf);
        src.CopyFrom(buf + 6);
        uint16_t type = (buf[12] << 8) | buf[13];
        Ptr<Packet> packet = Create<Packet>(buf + 14, len - 14);
        std::free(buf);
        if (src != Mac48Address::ConvertFrom(m_device->GetAddress()))
        {
            c.foreignSource++;
            return;
        }
        c.fromTap++;
        m_device->Send(packet, dst, type);
    }

    bool FromDevice(Ptr<NetDevice>,
                    Ptr<const Packet> packet,
                    uint16_t protocol,
                    const Address& from,
                    const Address& to,
                    NetDevice::PacketType type)
    {
        if (type == NetDevice::PACKET_OTHERHOST)
        {
            return true; // not for this node's host
        }
        uint32_t size = packet->GetSize();
        std::vector<uint8_t> frame(14 + size);
        Mac48Address::ConvertFrom(to).CopyTo(frame.data());
        Mac48Address::ConvertFrom(from).CopyTo(frame.data() + 6);
        frame[12] = protocol >> 8;
        frame[13] = protocol & 0xff;
        packet->CopyData(frame.data() + 14, size);
        Counters& c = g_counters[m_index];
        if (write(m_fd, frame.data(), frame.size()) == static_cast<ssize_t>(frame.size()))
        {
            c.toTap++;
        }
        else
        {
            c.tapWriteErrors++;
        }
        return true;
    }

    uint32_t m_index;
    uint32_t m_nodeId;
    Ptr<NetDevice> m_device;
    int m_fd;
    Ptr<ChunkReader> m_reader;
};

void
Reply(const std::string& json)
{
    std::cout << json << std::endl;
}

/// The commands on stdin: read on a thread of their own, each run in the simulation at
/// the current real time (where Ptrs may be touched, see TapGlue::FromTap).
class Commands : public SimpleRefCount<Commands>
{
  public:
    explicit Commands(NetDeviceContainer devices)
        : m_devices(devices)
    {
        m_reader = Create<ChunkReader>(STDIN_FILENO);
        m_reader->Start(STDIN_FILENO, MakeCallback(&Commands::FromStdin, this));
    }

    void Stop()
    {
        m_reader->Stop();
    }

  private:
    // The reader thread: whole lines to the simulation, nothing of ns-3's touched.
    void FromStdin(uint8_t* buf, ssize_t len)
    {
        m_partial.append(reinterpret_cast<char*>(buf), len);
        std::free(buf);
        for (size_t end; (end = m_partial.find('\n')) != std::string::npos;)
        {
            Simulator::ScheduleWithContext(Simulator::NO_CONTEXT,
                                           Seconds(0),
                                           MakeEvent(&Commands::Run, this,
                                                     m_partial.substr(0, end)));
            m_partial.erase(0, end + 1);
        }
    }

    void Run(std::string line)
    {
        std::istringstream in(line);
        std::string verb;
        std::string mode;
        uint32_t node = 0;
        if (!(in >> verb >> node >> mode) || verb != "rate")
        {
            Reply("{\"event\":\"error\",\"message\":\"unknown command (use: rate <node> "
                  "<WifiMode>)\"}");
            return;
        }
        if (node == 0 || node >= m_devices.GetN())
        {
            Reply("{\"event\":\"error\",\"message\":\"no station " + std::to_string(node) +
                  "\"}");
            return;
        }
        auto device = DynamicCast<WifiNetDevice>(m_devices.Get(node));
        std::list<WifiMode> modes = device->GetPhy()->GetModeList();
        modes.splice(modes.end(), device->GetPhy()->GetMcsList());
        if (std::none_of(modes.begin(), modes.end(), [&mode](const WifiMode& known) {
                return known.GetUniqueName() == mode;
            }))
        {
            Reply("{\"event\":\"error\",\"message\":\"station " + std::to_string(node) +
                  "'s PHY has no mode " + mode + "\"}");
            return;
        }
        device->GetRemoteStationManager()->SetAttribute("DataMode", StringValue(mode));
        std::ostringstream out;
        out << "{\"event\":\"rate\",\"node\":" << node << ",\"data_mode\":\"" << mode
            << "\",\"t\":" << Simulator::Now().GetSeconds() << "}";
        Reply(out.str());
    }

    NetDeviceContainer m_devices;
    Ptr<ChunkReader> m_reader;
    std::string m_partial; // the reader thread's: a line not yet complete
};

uint32_t
NodeOf(const std::string& context)
{
    // "/NodeList/<i>/DeviceList/..."
    return std::stoul(context.substr(10, context.find('/', 10) - 10));
}

void
OnMacTx(std::string ctx, Ptr<const Packet>)
{
    g_counters[NodeOf(ctx)].macTx++;
}

void
OnMacRx(std::string ctx, Ptr<const Packet>)
{
    g_counters[NodeOf(ctx)].macRx++;
}

void
OnEnqueue(std::string ctx, Ptr<const WifiMpdu> mpdu)
{
    if (mpdu->GetHeader().IsData())
    {
        g_counters[NodeOf(ctx)].enqueued++;
    }
}

void
OnAcked(std::string ctx, Ptr<const WifiMpdu>)
{
    g_counters[NodeOf(ctx)].acked++;
}

void
OnMpduTimeout(std::string ctx, uint8_t, Ptr<const WifiMpdu>, const WifiTxVector&)
{
    g_counters[NodeOf(ctx)].nacked++;
}

void
OnPsduTimeout(std::string ctx, uint8_t, Ptr<const WifiPsdu>, const WifiTxVector&)
{
    g_counters[NodeOf(ctx)].nacked++;
}

void
OnDropped(std::string ctx, WifiMacDropReason reason, Ptr<const WifiMpdu>)
{
    Counters& c = g_counters[NodeOf(ctx)];
    (reason == WIFI_MAC_DROP_REACHED_RETRY_LIMIT ? c.dropRetry : c.dropQueue)++;
}

void
OnPhyRxDrop(std::string ctx, Ptr<const Packet>, WifiPhyRxfailureReason)
{
    g_counters[NodeOf(ctx)].phyRxDrop++;
}

void
OnPhyState(std::string ctx, Time, Time duration, WifiPhyState state)
{
    if (state == WifiPhyState::TX)
    {
        g_counters[NodeOf(ctx)].txAirtime += duration.GetSeconds();
    }
}

// --- the pure simulation (--taps=0): the paper's workloads at MAC level, AoI at the AP ---
//
// A frame of --frameBytes leaves a station as MTU-sized MSDUs (as IP fragments do); the AP
// takes it as delivered when all of them came (a lost one loses the frame, as for UDP).
// push: each station's camera makes a frame every 1/--pushRate s (see Pusher). wiswarm: the AP polls the stations in turn (round robin: the
// Whittle index's order for equal links), a poll being one small frame; the polled
// station answers with its camera's freshest frame (100 fps); the next poll leaves when
// the answer is complete, or after a timeout.

constexpr uint32_t kFragment = 1472;
constexpr double kSampleRate = 100.0;
constexpr double kPollTimeout = 0.1;

/// What every MSDU carries: its station, frame, generation time and place in the frame.
struct Tag
{
    uint32_t station;
    uint32_t frame;
    double generated;
    uint16_t index;
    uint16_t count;
};

/// Time-average age of information of one station at the AP, from ``start`` on.
struct Age
{
    double start = 0;
    double last = 0;      // time of the last update of ``area``
    double freshest = 0;  // generation time of the freshest frame delivered
    double area = 0;
    uint64_t frames = 0;
    uint32_t current = UINT32_MAX; // frame being reassembled
    uint16_t got = 0;

    void Advance(double now)
    {
        if (now <= start)
        {
            return;
        }
        double from = std::max(last, start);
        // the age grows linearly from (from - freshest) to (now - freshest)
        area += (now - from) * ((from - freshest) + (now - freshest)) / 2;
        last = now;
    }

    void Deliver(double now, double generated)
    {
        Advance(now);
        last = now;
        if (now >= start)
        {
            frames++;
        }
        freshest = std::max(freshest, generated);
    }
};

std::vector<Age> g_ages;
uint32_t g_fragments = 1;
double g_warmup = 2.0;

void
SendFrame(Ptr<NetDevice> device, Address to, uint32_t station, uint32_t frame, double generated)
{
    for (uint16_t i = 0; i < g_fragments; i++)
    {
        Tag tag{station, frame, generated, i, static_cast<uint16_t>(g_fragments)};
        std::vector<uint8_t> bytes(kFragment, 0);
        std::memcpy(bytes.data(), &tag, sizeof(tag));
        device->Send(Create<Packet>(bytes.data(), bytes.size()), to, 0x0800);
    }
}

/// A station's camera pushing frames. ``blocking``: as a blocking UDP socket on Linux,
/// frames wait in the application's FIFO and their fragments enter the MAC queue as room
/// frees up (what our model does); otherwise each frame's fragments are thrown at the
/// queue at once, and a full queue drops them (what a tap without backpressure gives).
class Pusher : public SimpleRefCount<Pusher>
{
  public:
    Pusher(Ptr<NetDevice> device, Address ap, uint32_t station, double rate, bool blocking)
        : m_device(device),
          m_ap(ap),
          m_station(station),
          m_rate(rate),
          m_blocking(blocking)
    {
        Ptr<WifiMac> mac = DynamicCast<WifiNetDevice>(device)->GetMac();
        m_queue = mac->GetTxopQueue(mac->GetQosSupported() ? AC_BE : AC_BE_NQOS);
        if (blocking)
        {
            mac->TraceConnectWithoutContext("AckedMpdu", MakeCallback(&Pusher::Freed, this));
            mac->TraceConnectWithoutContext("DroppedMpdu",
                                            MakeCallback(&Pusher::FreedByDrop, this));
        }
    }

    void Tick()
    {
        double now = Simulator::Now().GetSeconds();
        if (m_blocking)
        {
            m_fifo.push_back(now);
            Pump();
        }
        else
        {
            SendFrame(m_device, m_ap, m_station, m_frame++, now);
        }
        Simulator::Schedule(Seconds(1.0 / m_rate), &Pusher::Tick, this);
    }

  private:
    void Freed(Ptr<const WifiMpdu>)
    {
        Simulator::ScheduleNow(&Pusher::Pump, this); // once the MPDU has left the queue
    }

    void FreedByDrop(WifiMacDropReason, Ptr<const WifiMpdu>)
    {
        Simulator::ScheduleNow(&Pusher::Pump, this);
    }

    void Pump()
    {
        while (!m_fifo.empty() && m_queue->GetNPackets() < m_queue->GetMaxSize().GetValue())
        {
            Tag tag{m_station, m_frame, m_fifo.front(), m_next,
                    static_cast<uint16_t>(g_fragments)};
            std::vector<uint8_t> bytes(kFragment, 0);
            std::memcpy(bytes.data(), &tag, sizeof(tag));
            m_device->Send(Create<Packet>(bytes.data(), bytes.size()), m_ap, 0x0800);
            if (++m_next == g_fragments)
            {
                m_next = 0;
                m_frame++;
                m_fifo.pop_front();
            }
        }
    }

    Ptr<NetDevice> m_device;
    Address m_ap;
    uint32_t m_station;
    double m_rate;
    bool m_blocking;
    Ptr<WifiMacQueue> m_queue;
    std::deque<double> m_fifo; // generation times of the frames waiting
    uint32_t m_frame = 0;
    uint16_t m_next = 0; // the next fragment of the frame at the FIFO's head
};

/// The AP's side of the pure simulation: reassembly, AoI, and (wiswarm) the polls.
class Collector : public SimpleRefCount<Collector>
{
  public:
    Collector(NetDeviceContainer devices, bool polling)
        : m_devices(devices),
          m_polling(polling)
    {
        devices.Get(0)->SetReceiveCallback(MakeCallback(&Collector::AtAp, this));
        for (uint32_t i = 1; i < devices.GetN(); i++)
        {
            devices.Get(i)->SetReceiveCallback(MakeCallback(&Collector::AtStation, this));
        }
    }

    void Poll()
    {
        m_next = m_next % (m_devices.GetN() - 1) + 1;
        m_awaiting = m_next;
        Simulator::Cancel(m_timeout);
        m_timeout = Simulator::Schedule(Seconds(kPollTimeout), &Collector::Poll, this);
        std::vector<uint8_t> poll(64, 0);
        m_devices.Get(0)->Send(Create<Packet>(poll.data(), poll.size()),
                               m_devices.Get(m_next)->GetAddress(), 0x0800);
    }

  private:
    bool AtStation(Ptr<NetDevice> device, Ptr<const Packet>, uint16_t, const Address&)
    {
        // a poll: answer with the camera's freshest frame
        double now = Simulator::Now().GetSeconds();
        double generated = std::floor(now * kSampleRate) / kSampleRate;
        uint32_t station = device->GetNode()->GetId();
        SendFrame(device, m_devices.Get(0)->GetAddress(), station, m_frames[station]++,
                  generated);
        return true;
    }

    bool AtAp(Ptr<NetDevice>, Ptr<const Packet> packet, uint16_t, const Address&)
    {
        Tag tag;
        packet->CopyData(reinterpret_cast<uint8_t*>(&tag), sizeof(tag));
        Age& age = g_ages[tag.station];
        if (tag.frame != age.current)
        {
            age.current = tag.frame;
            age.got = 0;
        }
        if (++age.got == tag.count)
        {
            age.Deliver(Simulator::Now().GetSeconds(), tag.generated);
            if (m_polling && tag.station == m_awaiting)
            {
                Poll();
            }
        }
        return true;
    }

    NetDeviceContainer m_devices;
    bool m_polling;
    uint32_t m_next = 0;
    uint32_t m_awaiting = 0;
    EventId m_timeout;
    std::map<uint32_t, uint32_t> m_frames;
};

void
PrintAges(double end)
{
    std::ostringstream out;
    out << "{\"event\":\"aoi\",\"window_s\":" << end - g_warmup << ",\"stations\":[";
    for (size_t i = 1; i < g_ages.size(); i++)
    {
        Age& age = g_ages[i];
        age.Advance(end);
        out << (i > 1 ? "," : "") << "{\"mean_aoi_s\":" << age.area / (end - g_warmup)
            << ",\"frames\":" << age.frames << "}";
    }
    out << "]}";
    *g_stats << out.str() << std::endl;
}

double g_maxLag = 0;
double g_hardLimit = 0;
double g_statsPeriod = 1;
double g_nextStats = 0;

void
PrintStats(const char* event)
{
    std::ostringstream out;
    out << "{\"event\":\"" << event << "\",\"t\":" << Simulator::Now().GetSeconds()
        << ",\"max_lag_ms\":" << g_maxLag * 1e3 << ",\"nodes\":[";
    for (size_t i = 0; i < g_counters.size(); i++)
    {
        const Counters& c = g_counters[i];
        out << (i ? "," : "") << "{\"from_tap\":" << c.fromTap << ",\"to_tap\":" << c.toTap
            << ",\"tap_write_errors\":" << c.tapWriteErrors
            << ",\"foreign_source\":" << c.foreignSource << ",\"mac_tx\":" << c.macTx
            << ",\"mac_rx\":" << c.macRx << ",\"acked\":" << c.acked
            << ",\"nacked\":" << c.nacked << ",\"drop_retry\":" << c.dropRetry
            << ",\"drop_queue\":" << c.dropQueue + (c.macTx - std::min(c.macTx, c.enqueued)) << ",\"phy_rx_drop\":" << c.phyRxDrop
            << ",\"tx_airtime_s\":" << c.txAirtime << "}";
    }
    out << "]}";
    *g_stats << out.str() << std::endl;
}

/// Every 2 ms: the lag of the simulation behind the wall clock, signals, stats.
void
WatchLag(Ptr<RealtimeSimulatorImpl> realtime)
{
    if (realtime)
    {
        double lag = (realtime->RealtimeNow() - Simulator::Now()).GetSeconds();
        g_maxLag = std::max(g_maxLag, lag);
        if (g_hardLimit > 0 && lag > g_hardLimit)
        {
            PrintStats("lag-exceeded");
            std::exit(3);
        }
    }
    if (g_stop)
    {
        Simulator::Stop();
        return;
    }
    if (Simulator::Now().GetSeconds() >= g_nextStats)
    {
        g_nextStats += g_statsPeriod;
        PrintStats("stats");
    }
    Simulator::Schedule(MilliSeconds(2), &WatchLag, realtime);
}

} // namespace

int
main(int argc, char** argv)
{
    uint32_t stations = 2;
    std::string standard = "80211g";
    std::string dataMode;
    std::string namespaces;
    std::string tap = "wifi0";
    std::string statsFile;
    bool taps = true;
    double hardLimitMs = 100;
    double duration = 0;
    uint32_t frameBytes = 50176;
    double pushRate = 50;
    std::string system = "push";
    bool blocking = true;
    uint32_t queuePackets = 500;
    uint32_t seed = 1;
    bool ampdu = true;
    int rtPriority = 10;
    CommandLine cmd(__FILE__);
    cmd.AddValue("stations", "stations (followers), besides the access point", stations);
    cmd.AddValue("standard", "80211g or 80211n (2.4 GHz)", standard);
    cmd.AddValue("dataMode", "data rate: an ns-3 WifiMode (default ErpOfdmRate24Mbps / HtMcs7)",
                 dataMode);
    cmd.AddValue("namespaces", "comma list: the AP's namespace, then each station's", namespaces);
    cmd.AddValue("tap", "the tap's name inside every namespace", tap);
    cmd.AddValue("taps", "1: real processes through taps, in real time; 0: pure simulation",
                 taps);
    cmd.AddValue("hardLimitMs", "largest lag behind the wall clock allowed (real time)",
                 hardLimitMs);
    cmd.AddValue("duration", "seconds to run (0: until SIGTERM)", duration);
    cmd.AddValue("statsFile", "where stats lines go (default stdout)", statsFile);
    cmd.AddValue("statsPeriod", "seconds between stats lines", g_statsPeriod);
    cmd.AddValue("frameBytes", "pure simulation: bytes per pushed frame", frameBytes);
    cmd.AddValue("pushRate", "pure simulation: frames/s each station pushes", pushRate);
    cmd.AddValue("system", "pure simulation: push or wiswarm (round-robin polls)", system);
    cmd.AddValue("blocking", "pure simulation, push: a blocking socket (1) or none (0)",
                 blocking);
    cmd.AddValue("warmup", "pure simulation: seconds before the AoI window opens", g_warmup);
    cmd.AddValue("queuePackets", "WifiMacQueue size (packets)", queuePackets);
    cmd.AddValue("rtPriority", "SCHED_RR priority in real time (0: none)", rtPriority);
    cmd.AddValue("ampdu", "802.11n: aggregate MPDUs (A-MPDU, ns-3's default)", ampdu);
    cmd.AddValue("seed", "run number of the random streams", seed);
    cmd.Parse(argc, argv);

    RngSeedManager::SetRun(seed);
    std::ofstream statsOut;
    if (!statsFile.empty())
    {
        statsOut.open(statsFile, std::ios::app);
        if (!statsOut)
        {
            Fail("cannot write " + statsFile);
        }
        g_stats = &statsOut;
    }
    if (taps && rtPriority > 0)
    {
        // Real time on a shared machine: other processes' bursts would otherwise delay
        // events by hundreds of ms (measured: 195 ms at load 5 on 2 cores, 3 ms with this).
        // The scenario sleeps between events, so it takes little of the CPU it may preempt.
        struct sched_param param{};
        param.sched_priority = rtPriority;
        if (sched_setscheduler(0, SCHED_RR, &param) != 0)
        {
            std::cerr << "wifi_medium: no real-time priority (" << std::strerror(errno)
                      << "): lag may grow when the machine is busy" << std::endl;
        }
    }
    g_hardLimit = hardLimitMs / 1e3;
    if (taps)
    {
        GlobalValue::Bind("SimulatorImplementationType",
                          StringValue("ns3::RealtimeSimulatorImpl"));
        Config::SetDefault("ns3::RealtimeSimulatorImpl::SynchronizationMode",
                           StringValue("HardLimit"));
        Config::SetDefault("ns3::RealtimeSimulatorImpl::HardLimit",
                           TimeValue(MilliSeconds(hardLimitMs)));
    }
    Config::SetDefault("ns3::WifiMacQueue::MaxSize",
                       QueueSizeValue(QueueSize(std::to_string(queuePackets) + "p")));
    // Frames stay queued until sent or the queue is full: aging them out after 500 ms
    // (ns-3's default) would be a loss no real 802.11 driver adds.
    Config::SetDefault("ns3::WifiMacQueue::MaxDelay", TimeValue(Seconds(3600)));

    std::vector<std::string> nsList = Split(namespaces);
    if (taps && nsList.size() != stations + 1)
    {
        Fail("--namespaces needs one entry per node (" +
             std::to_string(stations + 1) + ")");
    }

    NodeContainer nodes;
    nodes.Create(stations + 1);
    g_counters.resize(stations + 1);
    YansWifiChannelHelper channel = YansWifiChannelHelper::Default();
    YansWifiPhyHelper phy;
    phy.SetChannel(channel.Create());
    WifiHelper wifi;
    if (standard == "80211g")
    {
        wifi.SetStandard(WIFI_STANDARD_80211g);
        dataMode = dataMode.empty() ? "ErpOfdmRate24Mbps" : dataMode;
        wifi.SetRemoteStationManager("ns3::ConstantRateWifiManager", "DataMode",
                                     StringValue(dataMode), "ControlMode",
                                     StringValue("ErpOfdmRate6Mbps"));
    }
    else if (standard == "80211n")
    {
        wifi.SetStandard(WIFI_STANDARD_80211n);
        phy.Set("ChannelSettings", StringValue("{0, 20, BAND_2_4GHZ, 0}"));
        dataMode = dataMode.empty() ? "HtMcs7" : dataMode;
        wifi.SetRemoteStationManager("ns3::ConstantRateWifiManager", "DataMode",
                                     StringValue(dataMode), "ControlMode",
                                     StringValue("HtMcs0"));
    }
    else
    {
        Fail("--standard must be 80211g or 80211n, got " + standard);
    }
    if (!ampdu)
    {
        Config::SetDefault("ns3::WifiMac::BE_MaxAmpduSize", UintegerValue(0));
    }
    WifiMacHelper mac;
    Ssid ssid("wiswarm");
    mac.SetType("ns3::ApWifiMac", "Ssid", SsidValue(ssid));
    NetDeviceContainer devices = wifi.Install(phy, mac, nodes.Get(0));
    mac.SetType("ns3::StaWifiMac", "Ssid", SsidValue(ssid));
    for (uint32_t i = 1; i <= stations; i++)
    {
        devices.Add(wifi.Install(phy, mac, nodes.Get(i)));
    }
    MobilityHelper mobility;
    mobility.SetPositionAllocator("ns3::GridPositionAllocator", "MinX", DoubleValue(0),
                                  "MinY", DoubleValue(0), "DeltaX", DoubleValue(1),
                                  "DeltaY", DoubleValue(1), "GridWidth", UintegerValue(4),
                                  "LayoutType", StringValue("RowFirst"));
    mobility.SetMobilityModel("ns3::ConstantPositionMobilityModel");
    mobility.Install(nodes);

    const std::string dev = "/NodeList/*/DeviceList/*/$ns3::WifiNetDevice/";
    Config::Connect(dev + "Mac/MacTx", MakeCallback(&OnMacTx));
    Config::Connect(dev + "Mac/MacRx", MakeCallback(&OnMacRx));
    // A full queue refuses what arrives without a trace (ns-3.37: neither DroppedMpdu nor
    // the queue's Drop fire): counted as what the MAC took (MacTx) and its queue did not
    // (Enqueue; the best-effort queue: 802.11g's only one, 802.11n's for untagged traffic).
    for (uint32_t i = 0; i <= stations; i++)
    {
        Ptr<WifiMac> wifiMac = DynamicCast<WifiNetDevice>(devices.Get(i))->GetMac();
        Ptr<WifiMacQueue> queue = wifiMac->GetTxopQueue(wifiMac->GetQosSupported() ? AC_BE
                                                                                 : AC_BE_NQOS);
        queue->TraceConnect("Enqueue", "/NodeList/" + std::to_string(i) + "/",
                            MakeCallback(&OnEnqueue));
    }
    Config::Connect(dev + "Mac/AckedMpdu", MakeCallback(&OnAcked));
    Config::Connect(dev + "Mac/MpduResponseTimeout", MakeCallback(&OnMpduTimeout));
    Config::Connect(dev + "Mac/PsduResponseTimeout", MakeCallback(&OnPsduTimeout));
    Config::Connect(dev + "Mac/DroppedMpdu", MakeCallback(&OnDropped));
    Config::Connect(dev + "Phy/PhyRxDrop", MakeCallback(&OnPhyRxDrop));
    Config::Connect(dev + "Phy/State/State", MakeCallback(&OnPhyState));

    std::cout << "{\"event\":\"addresses\",\"macs\":[";
    for (uint32_t i = 0; i <= stations; i++)
    {
        std::cout << (i ? "," : "") << "\"" << Mac48Address::ConvertFrom(devices.Get(i)->GetAddress())
                  << "\"";
    }
    std::cout << "]}" << std::endl;
    std::vector<Ptr<TapGlue>> glue;
    std::vector<Ptr<Pusher>> pushers;
    if (taps)
    {
        std::string go;
        if (!std::getline(std::cin, go))
        {
            Fail("stdin closed before the taps were ready");
        }
        for (uint32_t i = 0; i <= stations; i++)
        {
            glue.push_back(Create<TapGlue>(i, devices.Get(i), OpenTap(nsList[i], tap)));
        }
    }
    Ptr<Collector> collector;
    if (!taps)
    {
        if (system != "push" && system != "wiswarm")
        {
            Fail("--system must be push or wiswarm, got " + system);
        }
        if (duration <= g_warmup)
        {
            Fail("--duration must exceed --warmup in a pure simulation");
        }
        g_fragments = (frameBytes + kFragment - 1) / kFragment;
        g_ages.resize(stations + 1);
        for (Age& age : g_ages)
        {
            age.start = g_warmup;
        }
        collector = Create<Collector>(devices, system == "wiswarm");
        Ptr<UniformRandomVariable> phase = CreateObject<UniformRandomVariable>();
        for (uint32_t i = 1; system == "push" && i <= stations; i++)
        {
            auto pusher = Create<Pusher>(devices.Get(i), devices.Get(0)->GetAddress(), i,
                                         pushRate, blocking);
            // After association (about 0.5 s), each camera at a phase of its own.
            Simulator::Schedule(Seconds(1.0 + phase->GetValue(0, 1.0 / pushRate)),
                                &Pusher::Tick, pusher);
            pushers.push_back(pusher);
        }
        if (system == "wiswarm")
        {
            Simulator::Schedule(Seconds(1.0), &Collector::Poll, collector);
        }
    }
    // After the "go" line: std::cin read nothing beyond it, the caller waiting for "ready"
    Ptr<Commands> commands = taps ? Create<Commands>(devices) : nullptr;
    std::signal(SIGTERM, OnSignal);
    std::signal(SIGINT, OnSignal);
    std::signal(SIGPIPE, SIG_IGN); // an answer nobody reads any more is not a crash
    Ptr<RealtimeSimulatorImpl> realtime =
        DynamicCast<RealtimeSimulatorImpl>(Simulator::GetImplementation());
    Simulator::ScheduleNow(&WatchLag, realtime);
    std::cout << "{\"event\":\"ready\",\"data_mode\":\"" << dataMode << "\"}" << std::endl;
    if (duration > 0)
    {
        Simulator::Stop(Seconds(duration));
    }
    Simulator::Run();
    PrintStats("end");
    if (!taps)
    {
        PrintAges(Simulator::Now().GetSeconds());
    }
    for (auto& g : glue)
    {
        g->Stop();
    }
    if (commands)
    {
        commands->Stop();
    }
    Simulator::Destroy();
    return 0;
}
