"""The paper's neural parts g_phi as factories for ``HybridRegressor(residual=...)``.

The MLP with two hidden layers of 128 units (``residual="mlp"``) and the CNN
with two hidden layers of 16 channels and batch norm (``residual="cnn"``) are
built into :mod:`sklearn_hybrid.residual`.  This module adds

* :func:`wind_tunnel_net` -- feed-forward net with two hidden layers of 2m
  units on ``(x, z)`` (``structure="compose"``, wind tunnel);
* :func:`light_tunnel_unet` -- a small U-Net that transforms the science image
  z (``structure="compose"``, light tunnel);
* :class:`ImageEncoder` and :class:`FrameDecoder` -- the image encoders and the
  decoder of the pendulum-images model (see
  :mod:`sklearn_hybrid.models.pendulum_images`).

A factory is called as ``factory(in_shapes, out_shape)`` inside every ``fit``,
so each fit starts from a fresh network.
"""

from __future__ import annotations

import math
from typing import Sequence

import torch
from torch import nn
from torch.nn import functional as F

from ..residual import MLP

__all__ = ["FeedForward", "wind_tunnel_net", "UNet", "light_tunnel_unet", "ImageEncoder",
           "FrameDecoder"]


def _bn(channels: int) -> nn.Module:
    # batch statistics in training and evaluation alike (no running averages), as in the
    # built-in ConvNet: the SAM second pass then cannot corrupt stored statistics
    return nn.BatchNorm2d(channels, track_running_stats=False)


class FeedForward(MLP):
    """MLP over several inputs, each first multiplied by a fixed scale.

    Parameters
    ----------
    in_shapes : sequence of tuple
        Per-sample shapes of the inputs, e.g. ``((m, 3), (m,))`` for ``(x, z)``.
    out_shape : tuple
        Per-sample output shape.
    hidden : sequence of int or None, default=None
        Hidden widths; None gives two layers of ``2 * prod(out_shape)`` (the
        paper's 2m).
    input_scales : sequence, optional
        One scale per input (a number or a tensor broadcastable to the input),
        applied before flattening so that inputs in very different units
        (degrees and loads) enter the first layer at similar magnitudes.
    activation : str, default="relu"
        Activation between layers.
    """

    def __init__(self, in_shapes: Sequence[tuple], out_shape: tuple,
                 hidden: Sequence[int] | None = None, input_scales: Sequence | None = None,
                 activation: str = "relu"):
        if hidden is None:
            hidden = (2 * math.prod(out_shape),) * 2
        super().__init__(in_shapes, out_shape, hidden=hidden, activation=activation)
        scales = [1.0] * len(in_shapes) if input_scales is None else list(input_scales)
        if len(scales) != len(in_shapes):
            raise ValueError(f"input_scales has {len(scales)} entries for {len(in_shapes)} inputs.")
        for i, s in enumerate(scales):
            self.register_buffer(f"scale_{i}", torch.as_tensor(s, dtype=torch.get_default_dtype()))
        self.n_inputs = len(scales)

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        scaled = [x * getattr(self, f"scale_{i}").to(x.dtype) for i, x in enumerate(inputs)]
        return super().forward(*scaled)


def wind_tunnel_net(in_shapes: Sequence[tuple], out_shape: tuple) -> nn.Module:
    """Feed-forward net of the wind-tunnel task: ``y = g(x, z)``, two hidden layers of 2m.

    The hatch (degrees, 0..45) is divided by 45 so that all three input
    channels lie in [0, 1]; z (Pa) enters as it is.

    Parameters
    ----------
    in_shapes : tuple
        ``((m, 3), (m,))``: the input window and the science output.
    out_shape : tuple
        ``(m,)``.

    Returns
    -------
    FeedForward
    """
    x_scale = torch.tensor([1.0, 1.0, 1.0 / 45.0])
    return FeedForward(in_shapes, out_shape, input_scales=[x_scale, 1.0])


def _conv_block(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(c_in, c_out, 3, padding=1), _bn(c_out), nn.ReLU(),
                         nn.Conv2d(c_out, c_out, 3, padding=1), _bn(c_out), nn.ReLU())


class UNet(nn.Module):
    """A small U-Net (Ronneberger et al. 2015) for images of any size.

    Parameters
    ----------
    in_channels, out_channels : int
        Channels of the input and output images.
    channels : sequence of int, default=(16, 32, 64)
        Channels per level; each level halves the resolution (max pooling) and
        the decoder upsamples back to the exact size of the matching skip.
    """

    def __init__(self, in_channels: int, out_channels: int, channels: Sequence[int] = (16, 32, 64)):
        super().__init__()
        widths = [in_channels, *channels]
        self.down = nn.ModuleList(_conv_block(a, b) for a, b in zip(widths[:-1], widths[1:]))
        self.up = nn.ModuleList(_conv_block(b + a, a) for a, b in zip(channels[:-1], channels[1:]))
        self.head = nn.Conv2d(channels[0], out_channels, 1)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        skips, h = [], image
        for i, block in enumerate(self.down):
            if i:
                h = F.max_pool2d(h, 2, ceil_mode=True)
            h = block(h)
            skips.append(h)
        for block, skip in zip(reversed(self.up), reversed(skips[:-1])):
            h = F.interpolate(h, size=skip.shape[-2:], mode="nearest")
            h = block(torch.cat([skip, h], dim=1))
        return self.head(h)


class _ImageResidual(nn.Module):
    """``g(x, z) = UNet(z)``: the network sees the science image only, not the settings x."""

    def __init__(self, in_shapes, out_shape, channels):
        super().__init__()
        z_shape = in_shapes[-1]
        self.unet = UNet(z_shape[0], out_shape[0], channels)

    def forward(self, x: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        return self.unet(z)


def light_tunnel_unet(in_shapes: Sequence[tuple], out_shape: tuple,
                      channels: Sequence[int] = (16, 32, 64)) -> nn.Module:
    """U-Net of the light-tunnel task: transforms the F3 image z into the camera image.

    Parameters
    ----------
    in_shapes : tuple
        ``((5,), (3, H, W))``: the settings x (not used by the net, so the
        colours must come through the science model) and the science image z.
    out_shape : tuple
        ``(3, H, W)``.
    channels : sequence of int, default=(16, 32, 64)
        Channels per U-Net level; bind other values with ``functools.partial``.

    Returns
    -------
    torch.nn.Module
        Called as ``g(x, z)``.
    """
    if len(in_shapes) != 2 or len(in_shapes[-1]) != 3:
        raise ValueError(f"light_tunnel_unet needs inputs (x, z) with an image z, got {in_shapes}.")
    return _ImageResidual(in_shapes, out_shape, channels)


class ImageEncoder(nn.Module):
    """Convolutional encoder of a stack of frames into a vector.

    Parameters
    ----------
    n_frames : int
        Input frames, stacked as channels.
    image_size : int
        Height and width of the frames.
    out_features : int
        Length of the code.
    channels : sequence of int, default=(32, 64, 64)
        Channels of the stride-2 convolutions (each with batch norm and ReLU).
    hidden : int, default=256
        Width of the fully connected layer after the convolutions.
    """

    def __init__(self, n_frames: int, image_size: int, out_features: int,
                 channels: Sequence[int] = (32, 64, 64), hidden: int = 256):
        super().__init__()
        layers, c_in, size = [], n_frames, image_size
        for c in channels:
            layers += [nn.Conv2d(c_in, c, 3, stride=2, padding=1), _bn(c), nn.ReLU()]
            c_in, size = c, (size + 1) // 2
        self.conv = nn.Sequential(*layers)
        self.fc = nn.Sequential(nn.Flatten(), nn.Linear(c_in * size * size, hidden), nn.ReLU(),
                                nn.Linear(hidden, out_features))

    def forward(self, frames: torch.Tensor) -> torch.Tensor:
        return self.fc(self.conv(frames))


class FrameDecoder(nn.Module):
    """Decoder of one frame from a small code: fully connected, then upsampling convolutions.

    The paper's decoder has fully connected hidden layers of 1152 units and
    convolutional hidden layers of 576 and 288 channels (the defaults); the
    fully connected part ends in a ``32 x s x s`` map (``s = image_size / 8``,
    1152 values for 48-pixel images) that three nearest-neighbour upsamplings
    by 2, each followed by a 3x3 convolution, bring to the image size.

    Parameters
    ----------
    in_features : int
        Length of the code of one frame.
    image_size : int
        Height and width of the output frame.
    fc_hidden : sequence of int, default=(1152, 1152)
        Hidden widths of the fully connected part.
    conv_channels : sequence of int, default=(576, 288)
        Hidden channels of the convolutional part (batch norm and ReLU).
    seed_channels : int, default=32
        Channels of the map that the fully connected part outputs.
    """

    def __init__(self, in_features: int, image_size: int, fc_hidden: Sequence[int] = (1152, 1152),
                 conv_channels: Sequence[int] = (576, 288), seed_channels: int = 32):
        super().__init__()
        n_up = len(conv_channels) + 1
        self.image_size = image_size
        self.seed_shape = (seed_channels, max(1, math.ceil(image_size / 2**n_up)))
        widths = [in_features, *fc_hidden]
        fc = []
        for a, b in zip(widths[:-1], widths[1:]):
            fc += [nn.Linear(a, b), nn.ReLU()]
        fc.append(nn.Linear(widths[-1], seed_channels * self.seed_shape[1] ** 2))
        self.fc = nn.Sequential(*fc)
        convs, c_in = [], seed_channels
        for c in conv_channels:
            convs.append(nn.Sequential(nn.Upsample(scale_factor=2), nn.Conv2d(c_in, c, 3, padding=1),
                                       _bn(c), nn.ReLU()))
            c_in = c
        convs.append(nn.Sequential(nn.Upsample(scale_factor=2), nn.Conv2d(c_in, 1, 3, padding=1)))
        self.conv = nn.Sequential(*convs)

    def forward(self, code: torch.Tensor) -> torch.Tensor:
        c, s = self.seed_shape
        h = self.conv(self.fc(code).reshape(len(code), c, s, s))
        if h.shape[-1] != self.image_size:
            h = F.interpolate(h, size=(self.image_size, self.image_size), mode="bilinear",
                              align_corners=False)
        return torch.sigmoid(h[:, 0])  # grey levels in [0, 1]
