// The fused late-warp + lens pass, vertex stage: one triangle that covers the whole panel
// (vertices (-1,-1), (3,-1), (-1,3) in NDC, from the vertex index; no vertex buffer). The lens
// model is evaluated per fragment (lens_warp.frag). Cost: 3 vertices per eye.
#version 450

void main() {
    const vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
