// A scene read off the frame loop's thread (SIGHUP, `load-scene`): start() reads and checks the
// glTF on a thread of its own; the loop polls take() between frames and swaps the scene in at a
// frame boundary, so reading a large file never stalls a frame. One read at a time. Cost: the
// glTF load (core/gltf.hpp) on another thread; take() is a non-blocking poll.
#pragma once

#include <filesystem>
#include <future>
#include <optional>

#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/result.hpp"

namespace hmdnode {

class SceneLoader {
  public:
    struct Done {
        std::filesystem::path path;
        Result<Scene> scene;
    };
    // True while a read is running or its result has not been taken.
    bool busy() const { return future_.valid(); }
    // Starts reading `path` (the caller checked !busy()).
    void start(const std::filesystem::path& path) {
        path_ = path;
        future_ = std::async(std::launch::async, [path] { return load_gltf(path); });
    }
    // The finished read, once; nullopt while none is finished.
    std::optional<Done> take() {
        if (!future_.valid() ||
            future_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
            return std::nullopt;
        return Done{path_, future_.get()};
    }

  private:
    std::filesystem::path path_;
    std::future<Result<Scene>> future_;
};

}  // namespace hmdnode
