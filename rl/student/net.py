"""The student's network: a small convolutional encoder of the depth image, its features
joined with the peg's own pose, an MLP to the 6-D action in [-1, 1]."""

from __future__ import annotations

import torch
from torch import nn

from rl.nets import mlp


class DepthEncoder(nn.Module):
    """(B, 1, H, W) depth in metres -> (B, features): four stride-2 convolutions (ReLU; 8,
    16, 32 and 32 channels: 0.2 G multiply-adds for 256 images of 64 x 64, so a gradient
    step takes tens of milliseconds on one core), then one linear layer. Depth is divided by
    the camera's far plane first, so inputs lie in [0, 1] whatever the camera."""

    def __init__(self, height: int, width: int, far: float, features: int) -> None:
        super().__init__()
        self.far = far
        self.conv = nn.Sequential(
            nn.Conv2d(1, 8, 5, stride=2, padding=2), nn.ReLU(),
            nn.Conv2d(8, 16, 3, stride=2, padding=1), nn.ReLU(),
            nn.Conv2d(16, 32, 3, stride=2, padding=1), nn.ReLU(),
            nn.Conv2d(32, 32, 3, stride=2, padding=1), nn.ReLU(),
            nn.Flatten(),
        )  # fmt: skip
        with torch.no_grad():
            n = self.conv(torch.zeros(1, 1, height, width)).shape[1]
        self.out = nn.Linear(n, features)

    def forward(self, depth: torch.Tensor) -> torch.Tensor:
        return torch.relu(self.out(self.conv(depth / self.far)))


class VisionPolicy(nn.Module):
    """(depth (B, 1, H, W), peg pose (B, 9)) -> action (B, 6) in [-1, 1]."""

    def __init__(
        self, height: int, width: int, far: float, features: int, hidden: tuple[int, ...]
    ) -> None:
        super().__init__()
        self.encoder = DepthEncoder(height, width, far, features)
        self.head = mlp(features + 9, hidden, 6, activation="relu")

    def forward(self, depth: torch.Tensor, pose: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self.head(torch.cat([self.encoder(depth), pose], dim=1)))
