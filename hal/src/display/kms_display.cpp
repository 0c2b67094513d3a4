// KMS direct output (the kernel's modesetting API through libdrm; after kmscube and Weston's
// drm-backend). Steps:
//  1. Open /dev/dri/cardN, become DRM master, enable universal planes and atomic (else legacy).
//  2. Pick the connector (name, EDID identity or non-desktop), its mode, a CRTC its encoders
//     can drive and that CRTC's primary plane (XRGB8888).
//  3. Three dumb buffers (CPU-mapped, XRGB8888) as framebuffers; set the mode with one atomic
//  commit
//     (ALLOW_MODESET) showing the first, black.
//  4. present(): convert the stereo frame (RGBA8, side by side) into the back buffer, wait until
//     the commit can make the target vsync, commit a page flip with DRM_MODE_PAGE_FLIP_EVENT and
//     wait for its event: its timestamp and sequence are the vsync the frame was shown at.
// Vsync grid: anchor + k * period, period from the mode's pixel clock / (htotal * vtotal); each
// event re-anchors it (hardware vblank). Drivers without a vblank interrupt (virtio-gpu, bochs)
// complete a flip at once with sequence 0; there the grid is the display's own timer and a
// commit waits for its vsync on the clock before it is made.
// Three buffers (shown, flip pending, written), so that a frame is written while the flip before
// it completes. Cost per present: one pass over the frame (width x height x 4 bytes) plus one
// ioctl and one event read; memory: three framebuffers.
// Zero-copy (attach_buffers): buffers a renderer draws into (GBM buffer objects of the GLES
// backend) become framebuffers once (ADDFB2 with their format, modifier and pitch), and present()
// flips the one its source names as the newest drawn, with no copy; the dumb buffers stay for the
// black first frame and for a present with no drawn buffer.
#include "hmdnode/hal/display/kms_display.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <sys/mman.h>
#include <unistd.h>
#include <xf86drm.h>
#include <xf86drmMode.h>

#include <algorithm>
#include <cassert>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>

#include <drm_fourcc.h>
#include <linux/dma-buf.h>
#include <sys/ioctl.h>

#include "hmdnode/hal/display/vsync_grid.hpp"

namespace hmdnode {
namespace {

std::string strerror_text(int e) {
    return std::strerror(e);
}

std::string hex(uint64_t v) {
    char b[24];
    std::snprintf(b, sizeof b, "%llx", static_cast<unsigned long long>(v));
    return b;
}

double mode_refresh_hz(const drmModeModeInfo& m) {
    if (m.htotal == 0 || m.vtotal == 0) return double(m.vrefresh);
    double hz = double(m.clock) * 1000.0 / (double(m.htotal) * double(m.vtotal));
    if (m.flags & DRM_MODE_FLAG_INTERLACE) hz *= 2.0;
    if (m.flags & DRM_MODE_FLAG_DBLSCAN) hz /= 2.0;
    if (m.vscan > 1) hz /= m.vscan;
    return hz;
}

std::string connector_name(const drmModeConnector& c) {
    const char* t = drmModeGetConnectorTypeName(c.connector_type);
    return std::string(t ? t : "Unknown") + "-" + std::to_string(c.connector_type_id);
}

const char* connection_name(drmModeConnection c) {
    switch (c) {
        case DRM_MODE_CONNECTED:
            return "connected";
        case DRM_MODE_DISCONNECTED:
            return "disconnected";
        default:
            return "unknown";
    }
}

// A property of a KMS object by name: its id and value (0, 0 when absent).
struct Prop {
    uint32_t id = 0;
    uint64_t value = 0;
};
std::map<std::string, Prop> object_props(int fd, uint32_t id, uint32_t type) {
    std::map<std::string, Prop> out;
    drmModeObjectProperties* ps = drmModeObjectGetProperties(fd, id, type);
    if (!ps) return out;
    for (uint32_t i = 0; i < ps->count_props; ++i) {
        drmModePropertyRes* p = drmModeGetProperty(fd, ps->props[i]);
        if (!p) continue;
        out[p->name] = Prop{p->prop_id, ps->prop_values[i]};
        drmModeFreeProperty(p);
    }
    drmModeFreeObjectProperties(ps);
    return out;
}

std::vector<std::string> card_paths() {
    std::vector<std::string> out;
    if (DIR* d = opendir("/dev/dri")) {
        while (dirent* e = readdir(d))
            if (std::strncmp(e->d_name, "card", 4) == 0)
                out.push_back(std::string("/dev/dri/") + e->d_name);
        closedir(d);
    }
    std::sort(out.begin(), out.end());
    return out;
}

Result<int> open_card(const std::string& path) {
    int fd = open(path.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0)
        return make_error(
            path + ": " + strerror_text(errno) +
            (errno == EACCES ? " (add the user to the video group: docs/udev.md)" : ""));
    return fd;
}

KmsConnectorInfo describe(int fd, const std::string& device, const drmModeConnector& c) {
    KmsConnectorInfo info;
    info.device = device;
    info.name = connector_name(c);
    info.connection = connection_name(c.connection);
    std::map<std::string, Prop> props = object_props(fd, c.connector_id, DRM_MODE_OBJECT_CONNECTOR);
    if (auto it = props.find("non-desktop"); it != props.end()) info.non_desktop = it->second.value;
    if (auto it = props.find("EDID"); it != props.end() && it->second.value) {
        if (drmModePropertyBlobRes* b = drmModeGetPropertyBlob(fd, uint32_t(it->second.value))) {
            Result<EdidIdentity> id =
                parse_edid_identity(static_cast<const uint8_t*>(b->data), b->length);
            if (id.ok()) info.edid = *id;
            drmModeFreePropertyBlob(b);
        }
    }
    for (int i = 0; i < c.count_modes; ++i)
        info.modes.push_back(KmsMode{c.modes[i].hdisplay, c.modes[i].vdisplay,
                                     mode_refresh_hz(c.modes[i]),
                                     (c.modes[i].type & DRM_MODE_TYPE_PREFERRED) != 0});
    return info;
}

std::string describe_choice(const std::vector<KmsConnectorInfo>& cs) {
    std::string s;
    for (const KmsConnectorInfo& c : cs) {
        if (!s.empty()) s += ", ";
        s += c.name + " (" + c.connection + (c.non_desktop ? ", non-desktop" : "");
        if (c.edid) {
            char id[16];
            std::snprintf(id, sizeof id, "%04X", c.edid->product);
            s += ", edid:" + c.edid->vendor + ":" + id;
        }
        s += ")";
    }
    return s.empty() ? "none" : s;
}

bool connector_matches(const KmsConnectorInfo& c, const std::string& want) {
    if (want == "non-desktop") return c.non_desktop;
    if (want.rfind("edid:", 0) == 0) {
        if (!c.edid) return false;
        char id[24];
        std::snprintf(id, sizeof id, "edid:%s:%04X", c.edid->vendor.c_str(), c.edid->product);
        return strcasecmp(id, want.c_str()) == 0;
    }
    return c.name == want;
}

struct DumbBuffer {
    uint32_t handle = 0, pitch = 0, fb = 0;
    uint64_t size = 0;
    uint8_t* map = nullptr;
};

class KmsDisplayImpl final : public KmsDisplay {
  public:
    KmsDisplayImpl(Clock& clock, const KmsDisplayConfig& config) : clock_(clock), config_(config) {}
    ~KmsDisplayImpl() override {
        if (fd_ < 0) return;
        (void)finish();
        // note: the CRTC keeps scanning out its last framebuffer until the next master sets
        // another; removing ours makes the kernel turn the CRTC off (the panel goes dark).
        for (uint32_t fb : attached_fbs_) drmModeRmFB(fd_, fb);
        for (DumbBuffer& b : buffers_) {
            if (b.map) munmap(b.map, b.size);
            if (b.fb) drmModeRmFB(fd_, b.fb);
            if (b.handle) {
                drm_mode_destroy_dumb d{};
                d.handle = b.handle;
                drmIoctl(fd_, DRM_IOCTL_MODE_DESTROY_DUMB, &d);
            }
        }
        if (mode_blob_) drmModeDestroyPropertyBlob(fd_, mode_blob_);
        close(fd_);
    }

    Status open_and_set(const std::string& device) {
        device_ = device;
        Result<int> fd = open_card(device);
        if (!fd.ok()) return fd.error();
        fd_ = *fd;
        const std::string where = "kms display " + device;
        if (!drmIsMaster(fd_) && drmSetMaster(fd_) != 0)
            return make_error(
                where + ": cannot become DRM master (" + strerror_text(errno) +
                "): another process, most likely a desktop compositor, holds the device. Stop it "
                "or switch to a free VT, or get the connector from the compositor as a DRM lease "
                "(docs/hardware.md, \"KMS output\")");
        drmSetClientCap(fd_, DRM_CLIENT_CAP_UNIVERSAL_PLANES, 1);
        // The kernel hides non-desktop connectors from clients that do not ask for atomic.
        atomic_ = !config_.force_legacy && drmSetClientCap(fd_, DRM_CLIENT_CAP_ATOMIC, 1) == 0;
        uint64_t mono = 0;
        if (drmGetCap(fd_, DRM_CAP_TIMESTAMP_MONOTONIC, &mono) != 0 || !mono)
            return make_error(where + ": page-flip timestamps are not CLOCK_MONOTONIC");
        uint64_t dumb = 0;
        if (drmGetCap(fd_, DRM_CAP_DUMB_BUFFER, &dumb) != 0 || !dumb)
            return make_error(where + ": the driver has no dumb buffers");

        drmModeRes* res = drmModeGetResources(fd_);
        if (!res) return make_error(where + ": not a KMS device (" + strerror_text(errno) + ")");
        Status st = choose(where, res);
        drmModeFreeResources(res);
        if (!st.ok()) return st;
        if (Status s = create_buffers(where); !s.ok()) return s;
        if (Status s = modeset(where); !s.ok()) return s;
        // Does the CRTC count vblanks? (virtio-gpu and bochs do not: the query fails.)
        drmVBlank vb{};
        vb.request.type = DRM_VBLANK_RELATIVE;
        if (crtc_index_ == 1)
            vb.request.type = drmVBlankSeqType(vb.request.type | DRM_VBLANK_SECONDARY);
        else if (crtc_index_ > 1)
            vb.request.type =
                drmVBlankSeqType(vb.request.type | ((crtc_index_ << DRM_VBLANK_HIGH_CRTC_SHIFT) &
                                                    DRM_VBLANK_HIGH_CRTC_MASK));
        hw_vblank_ = drmWaitVBlank(fd_, &vb) == 0;
        anchor_ns_ = hw_vblank_ ? int64_t(vb.reply.tval_sec) * kNsPerSecond +
                                      int64_t(vb.reply.tval_usec) * 1000
                                : clock_.now_ns();
        if (hw_vblank_ && anchor_ns_ == 0) anchor_ns_ = clock_.now_ns();
        return {};
    }

    DisplayInfo info() const override { return info_; }

    int64_t next_vsync_ns(int64_t t_ns) const override {
        return grid_vsync_after(anchor_ns_, period_ns_, t_ns);
    }

    int64_t free_vsync_ns(int64_t t_ns) const override {
        return grid_free_vsync(anchor_ns_, period_ns_, config_.latch_margin_ns, last_vsync_ns_,
                               t_ns);
    }

    int64_t photon_offset_ns() const override {
        // Scan-out of the middle row (a full-period scan-out assumed) + half the persistence.
        return period_ns_ / 2 + config_.persistence_ns / 2;
    }

    Result<PresentResult> present(const StereoImage* image, int64_t target_vsync_ns) override {
        // Zero-copy: the newest buffer the renderer drew. Else three dumb buffers: the one shown,
        // the one a pending flip will show, and the one written.
        const int attached = source_.drawn ? source_.drawn() : -1;
        if (attached >= int(attached_fbs_.size()))
            return make_error("kms display " + device_ + ": buffer " + std::to_string(attached) +
                              " was never attached");
        uint32_t fb = 0;
        if (attached >= 0) {
            fb = attached_fbs_[size_t(attached)];
        } else if (!image && !attached_fbs_.empty() && (pending_fb_ || front_fb_)) {
            // Zero-copy with nothing new drawn: the newest frame is flipped again (a vsync that
            // repeats it), not a stale dumb buffer.
            fb = pending_fb_ ? pending_fb_ : front_fb_;
        } else {
            int back = 0;
            while (buffers_[back].fb == front_fb_ || buffers_[back].fb == pending_fb_) ++back;
            if (image) copy_in(*image, buffers_[back]);
            fb = buffers_[back].fb;
        }
        // The flip before must be done before the next one is committed.
        if (Status st = finish(); !st.ok()) return st.error();
        // Commit when it can only make the target: after the vsync before it (a flip latches at
        // the first vblank after its commit) or, without vblank hardware, at its latch point.
        const int64_t commit_at = hw_vblank_ ? target_vsync_ns - period_ns_ + period_ns_ / 8
                                             : target_vsync_ns - config_.latch_margin_ns;
        if (clock_.now_ns() < commit_at) clock_.sleep_until_ns(commit_at);
        const int64_t commit_ns = clock_.now_ns();
        int rc;
        if (atomic_) {
            drmModeAtomicReq* req = drmModeAtomicAlloc();
            drmModeAtomicAddProperty(req, plane_, plane_props_["FB_ID"].id, fb);
            rc = drmModeAtomicCommit(fd_, req, DRM_MODE_PAGE_FLIP_EVENT | DRM_MODE_ATOMIC_NONBLOCK,
                                     this);
            drmModeAtomicFree(req);
        } else {
            rc = drmModePageFlip(fd_, crtc_, fb, DRM_MODE_PAGE_FLIP_EVENT, this);
        }
        if (rc != 0)
            return make_error("kms display " + device_ +
                              ": page flip failed: " + strerror_text(errno));
        flip_pending_ = true;
        pending_fb_ = fb;
        pending_commit_ns_ = commit_ns;
        if (attached >= 0) source_.committed(attached);
        // With a vblank the event says which vsync the frame made: wait for it. Without one the
        // display's timer is the vsync, so the frame made it if committed by then; its event is
        // collected by the next present (or finish()), which keeps the frame thread free.
        if (hw_vblank_)
            if (Status st = finish(); !st.ok()) return st.error();

        PresentResult r;
        r.frame_index = frame_index_++;
        r.target_vsync_ns = target_vsync_ns;
        // The event's vsync on the grid: the target when within half a period of it.
        const int64_t t = last_flip_.timestamp_ns;
        if (hw_vblank_) {
            const int64_t k = std::llround(double(t - target_vsync_ns) / double(period_ns_));
            r.vsync_ns = target_vsync_ns + k * period_ns_;
            if (r.vsync_ns <= last_vsync_ns_) r.vsync_ns = last_vsync_ns_ + period_ns_;
            anchor_ns_ = t;  // re-anchored on the true vsync (drift between the clocks)
        } else {
            // No vblank: the frame counts for the grid vsync its commit latched for.
            r.vsync_ns = commit_ns <= target_vsync_ns
                             ? target_vsync_ns
                             : next_vsync_ns(commit_ns + config_.latch_margin_ns - 1);
        }
        last_vsync_ns_ = r.vsync_ns;
        r.on_time = r.vsync_ns == target_vsync_ns;
        r.photon_time_ns = r.vsync_ns + photon_offset_ns();
        return r;
    }

    std::string modeset_path() const override {
        return atomic_                ? "atomic"
               : config_.force_legacy ? "legacy (forced by the configuration)"
                                      : "legacy (no atomic modesetting on this driver)";
    }
    bool hardware_vblank() const override { return hw_vblank_; }
    KmsMode mode() const override { return mode_info_; }
    std::string connector_name() const override { return connector_name_; }
    KmsFlip last_flip() const override { return last_flip_; }

    Status finish() override {
        if (!flip_pending_) return {};
        const int64_t timeout = std::max<int64_t>(4 * period_ns_, 200'000'000);
        if (Status st = wait_flip(timeout); !st.ok()) return st;
        last_flip_.commit_ns = pending_commit_ns_;
        front_fb_ = pending_fb_;
        pending_fb_ = 0;
        return {};
    }

    Result<ImageRGBA8> read_scanout() override {
        const std::string where = "kms display " + device_ + ": read-back";
        if (Status st = finish(); !st.ok()) return st.error();
        drmModeCrtc* c = drmModeGetCrtc(fd_, crtc_);
        if (!c) return make_error(where + ": GETCRTC: " + strerror_text(errno));
        const uint32_t fb_id = c->buffer_id;
        drmModeFreeCrtc(c);
        drmModeFB2* fb = drmModeGetFB2(fd_, fb_id);
        if (!fb)
            return make_error(where + ": GETFB2 " + std::to_string(fb_id) + ": " +
                              strerror_text(errno));
        const uint32_t handle = fb->handles[0], pitch = fb->pitches[0], offset = fb->offsets[0];
        const uint32_t format = fb->pixel_format;
        const uint64_t modifier =
            (fb->flags & DRM_MODE_FB_MODIFIERS) ? fb->modifier : DRM_FORMAT_MOD_INVALID;
        const int w = int(fb->width), h = int(fb->height);
        drmModeFreeFB2(fb);
        bool ours = false;
        for (const DumbBuffer& b : buffers_) ours = ours || b.handle == handle;
        for (uint32_t a : attached_handles_) ours = ours || a == handle;
        auto release = [&] {
            if (handle && !ours) {
                drm_gem_close g{};
                g.handle = handle;
                drmIoctl(fd_, DRM_IOCTL_GEM_CLOSE, &g);
            }
        };
        if (!handle) return make_error(where + ": GETFB2 gave no buffer handle (not master?)");
        const bool bgr = format == DRM_FORMAT_XRGB8888 || format == DRM_FORMAT_ARGB8888;
        if (!bgr && format != DRM_FORMAT_XBGR8888 && format != DRM_FORMAT_ABGR8888) {
            release();
            return make_error(where + ": framebuffer format 0x" + hex(format) +
                              " (reads XRGB8888, ARGB8888, XBGR8888, ABGR8888)");
        }
        if (modifier != DRM_FORMAT_MOD_INVALID && modifier != DRM_FORMAT_MOD_LINEAR) {
            release();
            return make_error(where + ": framebuffer modifier 0x" + hex(modifier) +
                              " is not linear: its bytes are not rows");
        }
        // A CPU map: the dumb-buffer map (dumb buffers, and the kms_swrast buffer objects, which
        // are dumb buffers), else the buffer's dma-buf (PRIME) with CPU-access sync around the
        // read.
        const size_t size = size_t(offset) + size_t(pitch) * size_t(h);
        void* p = MAP_FAILED;
        int dmabuf = -1;
        std::string why;
        drm_mode_map_dumb m{};
        m.handle = handle;
        if (drmIoctl(fd_, DRM_IOCTL_MODE_MAP_DUMB, &m) == 0)
            p = mmap(nullptr, size, PROT_READ, MAP_SHARED, fd_, off_t(m.offset));
        else
            why = "MAP_DUMB: " + strerror_text(errno);
        if (p == MAP_FAILED) {
            if (drmPrimeHandleToFD(fd_, handle, DRM_CLOEXEC, &dmabuf) == 0)
                p = mmap(nullptr, size, PROT_READ, MAP_SHARED, dmabuf, 0);
            if (p == MAP_FAILED) why += "; PRIME mmap: " + strerror_text(errno);
        }
        if (p == MAP_FAILED) {
            if (dmabuf >= 0) close(dmabuf);
            release();
            return make_error(where + ": no CPU map of the framebuffer (" + why + ")");
        }
        dma_buf_sync sync{};
        sync.flags = DMA_BUF_SYNC_START | DMA_BUF_SYNC_READ;
        if (dmabuf >= 0) ioctl(dmabuf, DMA_BUF_IOCTL_SYNC, &sync);
        ImageRGBA8 img;
        img.width = w;
        img.height = h;
        img.pixels.resize(size_t(w) * size_t(h) * 4);
        const int r = bgr ? 2 : 0, b = bgr ? 0 : 2;
        for (int y = 0; y < h; ++y) {
            const uint8_t* src = static_cast<const uint8_t*>(p) + offset + size_t(y) * pitch;
            uint8_t* dst = img.at(0, y);
            for (int x = 0; x < w; ++x, src += 4, dst += 4) {
                dst[0] = src[r];
                dst[1] = src[1];
                dst[2] = src[b];
                dst[3] = 255;
            }
        }
        if (dmabuf >= 0) {
            sync.flags = DMA_BUF_SYNC_END | DMA_BUF_SYNC_READ;
            ioctl(dmabuf, DMA_BUF_IOCTL_SYNC, &sync);
        }
        munmap(p, size);
        if (dmabuf >= 0) close(dmabuf);
        release();
        return img;
    }

    ScanoutTargetInfo scanout_target() const override {
        ScanoutTargetInfo t;
        t.drm_fd = fd_;
        t.device = device_;
        t.width = mode_info_.width;
        t.height = mode_info_.height;
        t.formats = plane_formats_;
        return t;
    }

    Status attach_buffers(std::span<const ScanoutBuffer> buffers, KmsBufferSource source) override {
        const std::string where = "kms display " + device_ + ": attaching scan-out buffers";
        if (!attached_fbs_.empty()) return make_error(where + ": buffers are attached already");
        if (!source.drawn || !source.committed)
            return make_error(where + ": the buffer source is incomplete");
        std::vector<uint32_t> fbs, handles;
        auto undo = [&] {
            for (uint32_t fb : fbs) drmModeRmFB(fd_, fb);
        };
        for (size_t i = 0; i < buffers.size(); ++i) {
            const ScanoutBuffer& b = buffers[i];
            const std::string which = where + ": buffer " + std::to_string(i);
            if (b.width != mode_info_.width || b.height != mode_info_.height) {
                undo();
                return make_error(which + " is " + std::to_string(b.width) + "x" +
                                  std::to_string(b.height) + ", the mode " +
                                  std::to_string(mode_info_.width) + "x" +
                                  std::to_string(mode_info_.height));
            }
            uint32_t fb = 0;
            uint64_t modifiers[4] = {b.modifier, b.modifier, b.modifier, b.modifier};
            for (int p = b.planes; p < 4; ++p) modifiers[p] = 0;
            const bool explicit_modifier = b.modifier != kDrmModInvalid;
            const int rc = drmModeAddFB2WithModifiers(
                fd_, uint32_t(b.width), uint32_t(b.height), b.fourcc, b.handles, b.pitches,
                b.offsets, explicit_modifier ? modifiers : nullptr, &fb,
                explicit_modifier ? DRM_MODE_FB_MODIFIERS : 0);
            if (rc != 0) {
                undo();
                return make_error(which + ": ADDFB2 (format 0x" + hex(b.fourcc) + ", modifier 0x" +
                                  hex(b.modifier) + ", pitch " + std::to_string(b.pitches[0]) +
                                  "): " + strerror_text(errno));
            }
            fbs.push_back(fb);
            handles.push_back(b.handles[0]);
        }
        attached_fbs_ = std::move(fbs);
        attached_handles_ = std::move(handles);
        source_ = std::move(source);
        return {};
    }

    std::string scanout_path() const override {
        return attached_fbs_.empty()
                   ? "dumb-buffer copy"
                   : "zero-copy (" + std::to_string(attached_fbs_.size()) + " attached buffers)";
    }

  private:
    Status choose(const std::string& where, drmModeRes* res) {
        std::vector<KmsConnectorInfo> all;
        std::vector<drmModeConnector*> conns;
        for (int i = 0; i < res->count_connectors; ++i)
            if (drmModeConnector* c = drmModeGetConnector(fd_, res->connectors[i])) {
                conns.push_back(c);
                all.push_back(describe(fd_, device_, *c));
            }
        int pick = -1;
        const std::string& want = config_.connector;
        std::vector<int> connected, hmds;
        for (size_t i = 0; i < all.size(); ++i)
            if (conns[i]->connection == DRM_MODE_CONNECTED) {
                connected.push_back(int(i));
                if (all[i].non_desktop) hmds.push_back(int(i));
            }
        if (!want.empty()) {
            for (int i : connected)
                if (connector_matches(all[size_t(i)], want)) pick = i;
        } else if (hmds.size() == 1) {
            pick = hmds[0];
        } else if (connected.size() == 1) {
            pick = connected[0];
        }
        Status st;
        if (pick < 0)
            st = make_error(
                where + ": display.connector " +
                (want.empty() ? std::string("(not given)") : "\"" + want + "\"") +
                " matches no single connected connector; connectors: " + describe_choice(all));
        else
            st = choose_mode_crtc_plane(where, res, *conns[size_t(pick)], all[size_t(pick)]);
        for (drmModeConnector* c : conns) drmModeFreeConnector(c);
        return st;
    }

    Status choose_mode_crtc_plane(const std::string& where, drmModeRes* res,
                                  const drmModeConnector& c, const KmsConnectorInfo& ci) {
        connector_ = c.connector_id;
        connector_name_ = ci.name;
        int m = -1;
        if (!config_.mode.empty()) {
            Result<KmsModeRequest> req = parse_kms_mode(config_.mode);
            if (!req.ok()) return make_error("display.mode: " + req.error().message);
            for (int i = 0; i < c.count_modes && m < 0; ++i)
                if (c.modes[i].hdisplay == req->width && c.modes[i].vdisplay == req->height &&
                    (req->refresh_hz == 0.0 ||
                     std::fabs(mode_refresh_hz(c.modes[i]) - req->refresh_hz) < 0.5))
                    m = i;
            if (m < 0) {
                std::string modes;
                for (const KmsMode& k : ci.modes) {
                    char b[48];
                    std::snprintf(b, sizeof b, "%s%dx%d@%.2f", modes.empty() ? "" : ", ", k.width,
                                  k.height, k.refresh_hz);
                    modes += b;
                }
                return make_error(where + ": display.mode \"" + config_.mode +
                                  "\" is not a mode of " + ci.name + " (modes: " + modes + ")");
            }
        } else {
            for (int i = 0; i < c.count_modes && m < 0; ++i)
                if (c.modes[i].type & DRM_MODE_TYPE_PREFERRED) m = i;
            if (m < 0 && c.count_modes > 0) m = 0;
            if (m < 0) return make_error(where + ": " + ci.name + " has no modes");
        }
        mode_ = c.modes[m];
        mode_info_ = ci.modes[size_t(m)];
        // The driver's timings give the rate; a mode without one (no clock or totals, vrefresh 0)
        // has no vsync grid to pace on.
        if (!(mode_info_.refresh_hz >= 1.0 && mode_info_.refresh_hz <= 1000.0)) {
            char b[64];
            std::snprintf(b, sizeof b, "%.3f", mode_info_.refresh_hz);
            return make_error(where + ": mode " + std::to_string(mode_info_.width) + "x" +
                              std::to_string(mode_info_.height) + " of " + ci.name +
                              " reports a refresh rate of " + b + " Hz");
        }
        period_ns_ = int64_t(std::llround(1e9 / mode_info_.refresh_hz));
        assert(period_ns_ > 0);

        // A CRTC one of its encoders can drive: the current one first.
        crtc_ = 0;
        for (int e = 0; e < c.count_encoders && !crtc_; ++e) {
            drmModeEncoder* enc = drmModeGetEncoder(fd_, c.encoders[e]);
            if (!enc) continue;
            for (int k = 0; k < res->count_crtcs && !crtc_; ++k)
                if ((enc->possible_crtcs & (1u << k)) &&
                    (enc->crtc_id == 0 || enc->crtc_id == res->crtcs[k])) {
                    crtc_ = res->crtcs[k];
                    crtc_index_ = k;
                }
            drmModeFreeEncoder(enc);
        }
        if (!crtc_) return make_error(where + ": no CRTC can drive " + ci.name);

        drmModePlaneRes* planes = drmModeGetPlaneResources(fd_);
        for (uint32_t i = 0; planes && i < planes->count_planes && !plane_; ++i) {
            drmModePlane* p = drmModeGetPlane(fd_, planes->planes[i]);
            if (!p) continue;
            std::map<std::string, Prop> props =
                object_props(fd_, p->plane_id, DRM_MODE_OBJECT_PLANE);
            const bool primary =
                props.count("type") && props["type"].value == DRM_PLANE_TYPE_PRIMARY;
            bool xrgb = false;
            for (uint32_t f = 0; f < p->count_formats; ++f)
                xrgb = xrgb || p->formats[f] == DRM_FORMAT_XRGB8888;
            if (primary && xrgb && (p->possible_crtcs & (1u << crtc_index_))) {
                plane_ = p->plane_id;
                plane_props_ = props;
                plane_formats_ = formats_of(*p, props);
            }
            drmModeFreePlane(p);
        }
        if (planes) drmModeFreePlaneResources(planes);
        // Legacy (no plane found): SetCrtc takes XRGB8888 everywhere.
        if (plane_formats_.empty())
            plane_formats_.push_back(ScanoutFormat{DRM_FORMAT_XRGB8888, kDrmModInvalid});
        if (!plane_ && atomic_)
            return make_error(where + ": no XRGB8888 primary plane for the CRTC of " + ci.name);

        info_.name = "kms " + ci.name + " on " + device_;
        info_.eye_width = mode_info_.width / 2;
        info_.eye_height = mode_info_.height;
        info_.refresh_hz = mode_info_.refresh_hz;
        info_.period_ns = period_ns_;
        info_.latch_margin_ns = config_.latch_margin_ns;
        info_.persistence_ns = config_.persistence_ns;
        return {};
    }

    Status create_buffers(const std::string& where) {
        for (DumbBuffer& b : buffers_) {
            drm_mode_create_dumb c{};
            c.width = uint32_t(mode_info_.width);
            c.height = uint32_t(mode_info_.height);
            c.bpp = 32;
            if (drmIoctl(fd_, DRM_IOCTL_MODE_CREATE_DUMB, &c) != 0)
                return make_error(where + ": CREATE_DUMB: " + strerror_text(errno));
            b.handle = c.handle;
            b.pitch = c.pitch;
            b.size = c.size;
            uint32_t handles[4] = {b.handle}, pitches[4] = {b.pitch}, offsets[4] = {0};
            if (drmModeAddFB2(fd_, c.width, c.height, DRM_FORMAT_XRGB8888, handles, pitches,
                              offsets, &b.fb, 0) != 0)
                return make_error(where + ": ADDFB2: " + strerror_text(errno));
            drm_mode_map_dumb m{};
            m.handle = b.handle;
            if (drmIoctl(fd_, DRM_IOCTL_MODE_MAP_DUMB, &m) != 0)
                return make_error(where + ": MAP_DUMB: " + strerror_text(errno));
            void* p =
                mmap(nullptr, b.size, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, off_t(m.offset));
            if (p == MAP_FAILED) return make_error(where + ": mmap: " + strerror_text(errno));
            b.map = static_cast<uint8_t*>(p);
            std::memset(b.map, 0, b.size);
        }
        return {};
    }

    Status modeset(const std::string& where) {
        const DumbBuffer& front = buffers_[0];
        front_fb_ = front.fb;
        if (!atomic_) {
            if (drmModeSetCrtc(fd_, crtc_, front.fb, 0, 0, &connector_, 1, &mode_) != 0)
                return make_error(where + ": SETCRTC (legacy modeset): " + strerror_text(errno));
            return {};
        }
        std::map<std::string, Prop> cp = object_props(fd_, connector_, DRM_MODE_OBJECT_CONNECTOR);
        std::map<std::string, Prop> rp = object_props(fd_, crtc_, DRM_MODE_OBJECT_CRTC);
        if (drmModeCreatePropertyBlob(fd_, &mode_, sizeof mode_, &mode_blob_) != 0)
            return make_error(where + ": mode blob: " + strerror_text(errno));
        drmModeAtomicReq* req = drmModeAtomicAlloc();
        const uint64_t w = uint64_t(mode_info_.width), h = uint64_t(mode_info_.height);
        drmModeAtomicAddProperty(req, connector_, cp["CRTC_ID"].id, crtc_);
        drmModeAtomicAddProperty(req, crtc_, rp["MODE_ID"].id, mode_blob_);
        drmModeAtomicAddProperty(req, crtc_, rp["ACTIVE"].id, 1);
        drmModeAtomicAddProperty(req, plane_, plane_props_["FB_ID"].id, front.fb);
        drmModeAtomicAddProperty(req, plane_, plane_props_["CRTC_ID"].id, crtc_);
        drmModeAtomicAddProperty(req, plane_, plane_props_["SRC_X"].id, 0);
        drmModeAtomicAddProperty(req, plane_, plane_props_["SRC_Y"].id, 0);
        drmModeAtomicAddProperty(req, plane_, plane_props_["SRC_W"].id, w << 16);
        drmModeAtomicAddProperty(req, plane_, plane_props_["SRC_H"].id, h << 16);
        drmModeAtomicAddProperty(req, plane_, plane_props_["CRTC_X"].id, 0);
        drmModeAtomicAddProperty(req, plane_, plane_props_["CRTC_Y"].id, 0);
        drmModeAtomicAddProperty(req, plane_, plane_props_["CRTC_W"].id, w);
        drmModeAtomicAddProperty(req, plane_, plane_props_["CRTC_H"].id, h);
        const int rc = drmModeAtomicCommit(fd_, req, DRM_MODE_ATOMIC_ALLOW_MODESET, nullptr);
        drmModeAtomicFree(req);
        if (rc != 0) return make_error(where + ": atomic modeset: " + strerror_text(errno));
        return {};
    }

    // RGBA8 bytes are the little-endian word 0xAABBGGRR; XRGB8888 is 0x00RRGGBB: a byte swap
    // and a shift per pixel (vectorised by the compiler).
    void copy_in(const StereoImage& image, DumbBuffer& b) {
        const int W = mode_info_.width, H = mode_info_.height;
        const bool covers = image.eye[0].width >= W / 2 && image.eye[1].width >= W / 2 &&
                            image.eye[0].height >= H && image.eye[1].height >= H && W % 2 == 0;
        if (!covers) std::memset(b.map, 0, b.size);
        for (int e = 0; e < 2; ++e) {
            const ImageRGBA8& eye = image.eye[e];
            const int x0 = e * (W / 2);
            const int w = std::min(eye.width, W / 2), h = std::min(eye.height, H);
            for (int y = 0; y < h; ++y) {
                uint32_t row[4096];
                const uint8_t* src = eye.at(0, y);
                uint8_t* dst = b.map + size_t(y) * b.pitch + size_t(x0) * 4;
                for (int x0r = 0; x0r < w; x0r += 4096) {
                    const int n = std::min(4096, w - x0r);
                    std::memcpy(row, src + size_t(x0r) * 4, size_t(n) * 4);
                    for (int x = 0; x < n; ++x) row[x] = __builtin_bswap32(row[x]) >> 8;
                    std::memcpy(dst + size_t(x0r) * 4, row, size_t(n) * 4);
                }
            }
        }
    }

    // The plane's formats with their modifiers: the IN_FORMATS blob where the driver has one,
    // else its format list with the implicit layout.
    std::vector<ScanoutFormat> formats_of(const drmModePlane& p,
                                          const std::map<std::string, Prop>& props) const {
        std::vector<ScanoutFormat> out;
        auto it = props.find("IN_FORMATS");
        if (it != props.end() && it->second.value)
            if (drmModePropertyBlobRes* blob =
                    drmModeGetPropertyBlob(fd_, uint32_t(it->second.value))) {
                drmModeFormatModifierIterator iter{};
                while (drmModeFormatModifierBlobIterNext(blob, &iter))
                    out.push_back(ScanoutFormat{iter.fmt, iter.mod});
                drmModeFreePropertyBlob(blob);
            }
        if (out.empty())
            for (uint32_t f = 0; f < p.count_formats; ++f)
                out.push_back(ScanoutFormat{p.formats[f], kDrmModInvalid});
        return out;
    }

    static void on_flip(int, unsigned int sequence, unsigned int sec, unsigned int usec,
                        unsigned int, void* user) {
        auto* self = static_cast<KmsDisplayImpl*>(user);
        self->last_flip_.sequence = sequence;
        self->last_flip_.timestamp_ns = int64_t(sec) * kNsPerSecond + int64_t(usec) * 1000;
        self->flip_pending_ = false;
    }

    Status wait_flip(int64_t timeout_ns) {
        drmEventContext ev{};
        ev.version = 3;
        ev.page_flip_handler2 = &KmsDisplayImpl::on_flip;
        const int64_t deadline = clock_.now_ns() + timeout_ns;
        while (flip_pending_) {
            const int64_t left = deadline - clock_.now_ns();
            if (left <= 0)
                return make_error("kms display " + device_ + ": no page-flip event within " +
                                  std::to_string(timeout_ns / 1'000'000) + " ms");
            pollfd p{fd_, POLLIN, 0};
            const int n = poll(&p, 1, int(left / 1'000'000) + 1);
            if (n < 0 && errno != EINTR)
                return make_error("kms display " + device_ + ": poll: " + strerror_text(errno));
            if (n > 0 && drmHandleEvent(fd_, &ev) != 0)
                return make_error("kms display " + device_ + ": reading DRM events failed");
        }
        return {};
    }

    Clock& clock_;
    KmsDisplayConfig config_;
    std::string device_;
    int fd_ = -1;
    bool atomic_ = false;
    bool hw_vblank_ = false;
    uint32_t connector_ = 0, crtc_ = 0, plane_ = 0, mode_blob_ = 0;
    int crtc_index_ = 0;
    std::string connector_name_;
    std::map<std::string, Prop> plane_props_;
    drmModeModeInfo mode_{};
    KmsMode mode_info_;
    int64_t period_ns_ = 0;
    DisplayInfo info_;
    DumbBuffer buffers_[3];
    uint32_t front_fb_ = 0, pending_fb_ = 0;  // framebuffer ids: shown, flip pending (0: none)
    std::vector<uint32_t> attached_fbs_;      // attach_buffers()'s framebuffers
    std::vector<uint32_t> attached_handles_;  // their GEM handles (the renderer's)
    KmsBufferSource source_;
    std::vector<ScanoutFormat> plane_formats_;
    int64_t pending_commit_ns_ = 0;
    bool flip_pending_ = false;
    KmsFlip last_flip_;
    uint64_t frame_index_ = 0;
    int64_t anchor_ns_ = 0;
    int64_t last_vsync_ns_ = INT64_MIN;
};

}  // namespace

Result<EdidIdentity> parse_edid_identity(const uint8_t* bytes, size_t size) {
    static const uint8_t kHeader[8] = {0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x00};
    if (size < 128)
        return make_error("EDID: " + std::to_string(size) + " bytes, a base block has 128");
    for (int i = 0; i < 8; ++i)
        if (bytes[i] != kHeader[i])
            return make_error("EDID: byte " + std::to_string(i) + " is not the fixed header");
    uint8_t sum = 0;
    for (int i = 0; i < 128; ++i) sum = uint8_t(sum + bytes[i]);
    if (sum != 0) return make_error("EDID: base block checksum (byte 127) does not add up to 0");
    const unsigned v = (unsigned(bytes[8]) << 8) | bytes[9];
    EdidIdentity id;
    for (int shift : {10, 5, 0}) {
        const unsigned letter = (v >> shift) & 0x1f;
        if (letter < 1 || letter > 26)
            return make_error("EDID: bytes 8-9: vendor letter " + std::to_string(letter) +
                              " is not A-Z");
        id.vendor += char('A' + letter - 1);
    }
    id.product = uint16_t(bytes[10] | (unsigned(bytes[11]) << 8));
    // note: the first monitor name descriptor only (a block may carry several).
    for (int d = 54; d + 18 <= 126 && id.monitor_name.empty(); d += 18)
        if (bytes[d] == 0 && bytes[d + 1] == 0 && bytes[d + 3] == 0xfc) {
            for (int i = 5; i < 18 && bytes[d + i] != 0x0a; ++i)
                if (bytes[d + i] >= 0x20 && bytes[d + i] < 0x7f)
                    id.monitor_name += char(bytes[d + i]);
            while (!id.monitor_name.empty() && id.monitor_name.back() == ' ')
                id.monitor_name.pop_back();
        }
    return id;
}

Result<KmsModeRequest> parse_kms_mode(std::string_view text) {
    KmsModeRequest r;
    const std::string s(text);
    char tail = 0;
    double hz = 0.0;
    int n = std::sscanf(s.c_str(), "%dx%d@%lf%c", &r.width, &r.height, &hz, &tail);
    const bool plain = n == 2 && s.find('@') == std::string::npos;
    if (!(n == 3 || plain) || s.find_first_not_of("0123456789x@.") != std::string::npos ||
        r.width < 1 || r.height < 1 || r.width > 16384 || r.height > 16384 ||
        (n == 3 && !(hz >= 1.0 && hz <= 1000.0)))
        return make_error("\"" + s +
                          "\" is not WIDTHxHEIGHT@HZ (e.g. 2880x1600@90) or WIDTHxHEIGHT");
    r.refresh_hz = n == 3 ? hz : 0.0;
    return r;
}

Result<std::vector<KmsConnectorInfo>> list_kms_connectors(const std::string& device) {
    std::vector<KmsConnectorInfo> out;
    std::vector<std::string> paths = device.empty() ? card_paths() : std::vector{device};
    for (const std::string& path : paths) {
        Result<int> fd = open_card(path);
        if (!fd.ok()) return fd.error();
        drmSetClientCap(*fd, DRM_CLIENT_CAP_UNIVERSAL_PLANES, 1);
        drmSetClientCap(*fd, DRM_CLIENT_CAP_ATOMIC, 1);  // non-desktop connectors need it
        if (drmModeRes* res = drmModeGetResources(*fd)) {
            for (int i = 0; i < res->count_connectors; ++i)
                if (drmModeConnector* c = drmModeGetConnector(*fd, res->connectors[i])) {
                    out.push_back(describe(*fd, path, *c));
                    drmModeFreeConnector(c);
                }
            drmModeFreeResources(res);
        }
        close(*fd);
    }
    return out;
}

Result<std::unique_ptr<KmsDisplay>> create_kms_display(Clock& clock,
                                                       const KmsDisplayConfig& config) {
    if (clock.is_simulated())
        return make_error("kms display: needs the system clock (page flips happen in real time)");
    if (!config.mode.empty())
        if (Result<KmsModeRequest> m = parse_kms_mode(config.mode); !m.ok())
            return make_error("display.mode: " + m.error().message);
    std::vector<std::string> paths =
        config.device.empty() ? card_paths() : std::vector{config.device};
    if (paths.empty())
        return make_error(
            "kms display: no /dev/dri/card* (no KMS driver loaded; docs/hardware.md)");
    std::string errors;
    for (const std::string& path : paths) {
        auto d = std::make_unique<KmsDisplayImpl>(clock, config);
        Status st = d->open_and_set(path);
        if (st.ok()) return std::unique_ptr<KmsDisplay>(std::move(d));
        errors += (errors.empty() ? "" : "; ") + st.error().message;
    }
    return make_error(errors);
}

}  // namespace hmdnode
