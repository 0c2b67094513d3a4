// A USB device's HID interfaces as one Transport, and the backend decorator that groups a
// backend's interfaces by device: interface_group.hpp. A k-way merge by host time over one
// pending report per part; secondary parts read on threads (hidapi) or polled on the caller's
// thread (libusb, whose transports share one event loop). Learnt from libsurvive's Vive driver
// (driver_vive.c opens the HMD's IMU and lightcap interfaces of one device and handles both from
// one event loop) and Monado's vive_device.c (one thread per interface, the light sensor one
// beside the IMU one); here one stream keeps the light path's order of arrival.
// Cost: O(parts) per report; one report copy; threads: a locked queue push and pop per report.
#include "hmdnode/hal/transport/interface_group.hpp"

#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "transport/hidapi_transport.hpp"

namespace hmdnode {
namespace {

constexpr int kSliceMs = 2;              // the primary's read while nothing is at hand
constexpr int kReaderTimeoutMs = 20;     // a reader thread's read: bounds the reaction to close
constexpr size_t kQueueCapacity = 4096;  // per secondary part (threads)
constexpr size_t kPrimaryHeld = 256;     // the primary's reports drained ahead

// One secondary part read on a thread of its own into a bounded queue.
class PartReader {
  public:
    PartReader(Transport& part, int index) : part_(part) {
        thread_ = std::thread([this, index] {
            const std::string name = "hmdnode-if" + std::to_string(index);
            pthread_setname_np(pthread_self(), name.c_str());
            run();
        });
    }
    ~PartReader() {
        stop_.store(true);
        thread_.join();
    }
    PartReader(const PartReader&) = delete;
    PartReader& operator=(const PartReader&) = delete;

    // The oldest queued report, if any; the part's error once the queue is drained.
    Result<std::optional<InputReport>> take() {
        std::lock_guard lock(mutex_);
        if (!queue_.empty()) {
            InputReport r = std::move(queue_.front());
            queue_.pop_front();
            return std::optional<InputReport>{std::move(r)};
        }
        if (!error_.empty()) return make_error(error_);
        return std::optional<InputReport>{};
    }
    bool done() const {
        std::lock_guard lock(mutex_);
        return queue_.empty() && (finished_ || !error_.empty());
    }

  private:
    void run() {
        while (!stop_.load()) {
            auto r = part_.read_input(kReaderTimeoutMs);
            std::lock_guard lock(mutex_);
            if (!r) {
                error_ = r.error().message;
                return;
            }
            if (!r->has_value()) {
                if (part_.finished()) {
                    finished_ = true;
                    return;
                }
                continue;
            }
            // note: a caller that stopped reading keeps the newest kQueueCapacity
            if (queue_.size() >= kQueueCapacity) queue_.pop_front();
            queue_.push_back(std::move(**r));
        }
    }

    Transport& part_;
    std::atomic<bool> stop_{false};
    mutable std::mutex mutex_;  // guards queue_, error_, finished_
    std::deque<InputReport> queue_;
    std::string error_;
    bool finished_ = false;
    std::thread thread_;  // last: started once the members above exist
};

class MergedTransport final : public Transport {
  public:
    MergedTransport(std::vector<std::unique_ptr<Transport>> parts, InterfaceReading reading)
        : parts_(std::move(parts)), reading_(reading), pending_(parts_.size()) {
        if (reading_ == InterfaceReading::threads)
            for (size_t i = 1; i < parts_.size(); ++i)
                readers_.push_back(std::make_unique<PartReader>(*parts_[i], int(i)));
    }
    ~MergedTransport() override {
        readers_.clear();  // joins the threads before the parts they read go
    }

    DeviceId id() const override { return parts_[0]->id(); }

    Result<std::optional<InputReport>> read_input(int timeout_ms) override {
        const int64_t deadline =
            timeout_ms < 0 ? -1 : detail::monotonic_now_ns() + int64_t{timeout_ms} * 1'000'000;
        while (true) {
            // The secondaries first: a report at hand there means the primary is not waited for.
            bool any = false;
            if (Status st = fill_secondaries(&any); !st) return st.error();
            // The primary: waited for in a slice when nothing is at hand, then drained of what
            // it holds (up to kPrimaryHeld): its reports are stamped when read, and a hidraw
            // node keeps only 64.
            for (int k = 0; primary_.size() < kPrimaryHeld; ++k) {
                int slice = 0;
                if (k == 0 && primary_.empty() && !any && timeout_ms != 0) {
                    slice = kSliceMs;
                    if (deadline >= 0) {
                        const int64_t left_ms =
                            (deadline - detail::monotonic_now_ns() + 999'999) / 1'000'000;
                        slice = int(std::clamp<int64_t>(left_ms, 0, kSliceMs));
                    }
                }
                auto r = parts_[0]->read_input(slice);
                if (!r) return r.error();
                if (!r->has_value()) break;
                primary_.push_back(std::move(**r));
            }
            // Again after the primary's wait: what arrived meanwhile is older than its report.
            if (Status st = fill_secondaries(&any); !st) return st.error();
            // The oldest report at hand; the primary's first on a tie.
            size_t best = parts_.size();
            int64_t best_t = 0;
            if (!primary_.empty()) best = 0, best_t = primary_.front().host_time_ns;
            for (size_t i = 1; i < parts_.size(); ++i)
                if (pending_[i] && (best == parts_.size() || pending_[i]->host_time_ns < best_t))
                    best = i, best_t = pending_[i]->host_time_ns;
            if (best == 0) {
                InputReport r = std::move(primary_.front());
                primary_.pop_front();
                return std::optional<InputReport>{std::move(r)};
            }
            if (best < parts_.size()) {
                InputReport r = std::move(*pending_[best]);
                pending_[best].reset();
                return std::optional<InputReport>{std::move(r)};
            }
            if (finished() || timeout_ms == 0) return std::optional<InputReport>{};
            if (deadline >= 0 && detail::monotonic_now_ns() >= deadline)
                return std::optional<InputReport>{};
        }
    }

    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t size) override {
        return parts_[0]->get_feature(report_id, size);
    }
    Status set_feature(std::span<const uint8_t> data) override {
        return parts_[0]->set_feature(data);
    }
    Status write_output(std::span<const uint8_t> data) override {
        return parts_[0]->write_output(data);
    }

    // Every part has nothing more to give and nothing is left at hand.
    bool finished() const override {
        if (!primary_.empty()) return false;
        for (size_t i = 0; i < parts_.size(); ++i) {
            if (pending_[i]) return false;
            if (i > 0 && reading_ == InterfaceReading::threads) {
                if (!readers_[i - 1]->done()) return false;
            } else if (!parts_[i]->finished()) {
                return false;
            }
        }
        return true;
    }
    bool replayed() const override { return parts_[0]->replayed(); }

  private:
    // A report at hand for every secondary that has one; *any: some secondary has one.
    Status fill_secondaries(bool* any) {
        for (size_t i = 1; i < parts_.size(); ++i) {
            if (!pending_[i]) {
                auto r = reading_ == InterfaceReading::threads ? readers_[i - 1]->take()
                                                               : parts_[i]->read_input(0);
                if (!r) return r.error();
                if (r->has_value()) pending_[i] = std::move(**r);
            }
            *any = *any || pending_[i].has_value();
        }
        return {};
    }

    std::vector<std::unique_ptr<Transport>> parts_;
    InterfaceReading reading_;
    std::deque<InputReport> primary_;                   // the primary's reports at hand
    std::vector<std::optional<InputReport>> pending_;   // one at hand per other part ([0] unused)
    std::vector<std::unique_ptr<PartReader>> readers_;  // threads: parts 1.. (last: joined first)
};

class GroupedBackend final : public TransportBackend {
  public:
    GroupedBackend(std::unique_ptr<TransportBackend> inner, InterfaceReading reading)
        : inner_(std::move(inner)), reading_(reading) {}

    std::string name() const override { return inner_->name(); }

    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) override {
        auto ids = inner_->enumerate(filter);
        if (!ids) return ids.error();
        std::vector<DeviceId> out;
        std::map<std::string, size_t> device_at;  // usb_device -> its entry in out
        for (DeviceId& id : *ids) {
            if (id.usb_device.empty()) {
                out.push_back(std::move(id));
                continue;
            }
            auto [it, fresh] = device_at.try_emplace(id.usb_device, out.size());
            if (fresh)
                out.push_back(std::move(id));
            else if (id.interface_number < out[it->second].interface_number)
                out[it->second] = std::move(id);
        }
        return out;
    }

    Result<std::unique_ptr<Transport>> open(const DeviceId& id) override {
        if (id.usb_device.empty()) return inner_->open(id);
        DeviceFilter same;
        same.vendor_id = id.vendor_id;
        same.product_id = id.product_id;
        auto ids = inner_->enumerate(same);
        if (!ids) return ids.error();
        std::vector<DeviceId> siblings;
        for (DeviceId& s : *ids)
            if (s.usb_device == id.usb_device && s.path != id.path)
                siblings.push_back(std::move(s));
        std::sort(siblings.begin(), siblings.end(), [](const DeviceId& a, const DeviceId& b) {
            return a.interface_number < b.interface_number;
        });
        std::vector<std::unique_ptr<Transport>> parts;
        auto primary = inner_->open(id);
        if (!primary) return primary.error();
        parts.push_back(std::move(*primary));
        for (const DeviceId& s : siblings) {
            auto t = inner_->open(s);
            if (!t)
                return make_error(id.usb_device + ": interface " +
                                  std::to_string(s.interface_number) + " (" + s.path +
                                  ") of the device would not open, so its reports (a lighthouse "
                                  "device's light) would be missing: " +
                                  t.error().message);
            parts.push_back(std::move(*t));
        }
        return merge_interfaces(std::move(parts), reading_);
    }

    Result<std::unique_ptr<HotplugMonitor>> watch(const DeviceFilter& filter) override {
        return inner_->watch(filter);
    }

  private:
    std::unique_ptr<TransportBackend> inner_;
    InterfaceReading reading_;
};

}  // namespace

InterfaceReading interface_reading_for(const std::string& backend_name) {
    return backend_name == "libusb" ? InterfaceReading::polled : InterfaceReading::threads;
}

Result<std::unique_ptr<Transport>> merge_interfaces(std::vector<std::unique_ptr<Transport>> parts,
                                                    InterfaceReading reading) {
    if (parts.empty()) return make_error("merging interfaces: no interface to merge");
    for (size_t i = 0; i < parts.size(); ++i)
        if (!parts[i])
            return make_error("merging interfaces: interface " + std::to_string(i) + " is null");
    if (parts.size() == 1) return std::move(parts[0]);
    return std::unique_ptr<Transport>(new MergedTransport(std::move(parts), reading));
}

std::unique_ptr<TransportBackend> group_interfaces(std::unique_ptr<TransportBackend> inner,
                                                   InterfaceReading reading) {
    return std::unique_ptr<TransportBackend>(new GroupedBackend(std::move(inner), reading));
}

}  // namespace hmdnode
